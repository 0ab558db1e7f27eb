"""The console's per-flow rate, bandwidth and jitter (issue 27, Build 1: "computed correctly"), from given
arrival times: no clock, no bus, so each figure is exact."""

from __future__ import annotations

import pytest

from uavbus.web.console import Flow


def flow(times: list[float], size: int = 100) -> Flow:
    f = Flow("imuOut", "fcs20")
    for t in times:
        f.samples.append((t, size, None))
        f.total += 1
    return f


def test_a_steady_flow_younger_than_the_window_is_not_diluted() -> None:
    # 50 Hz for 3 s (151 messages) read through a 5 s window: 50 msg/s, not 151/5 = 30.2.
    f = flow([10.0 + i * 0.02 for i in range(151)])
    s = f.stats(now=13.01, window_s=5.0, started=9.0)
    assert s["rate_hz"] == pytest.approx(50.0, abs=0.01)
    assert s["bytes_per_s"] == pytest.approx(5000.0, abs=0.5)
    assert s["jitter_ms"] == pytest.approx(0.0, abs=0.01) and s["mean_gap_ms"] == pytest.approx(20.0, abs=0.01)
    assert s["messages"] == 151 and s["last_age_s"] == pytest.approx(0.01, abs=1e-6)


def test_jitter_is_the_spread_of_the_gaps() -> None:
    # Gaps alternate 15 and 25 ms: mean 20 ms (50 Hz), standard deviation 5 ms.
    t, times = 0.0, []
    for i in range(101):
        times.append(t)
        t += 0.015 if i % 2 == 0 else 0.025
    s = flow(times, size=64).stats(now=times[-1] + 0.001, window_s=5.0, started=0.0)
    assert s["rate_hz"] == pytest.approx(50.0, abs=0.01) and s["jitter_ms"] == pytest.approx(5.0, abs=0.01)
    assert s["bytes_per_s"] == pytest.approx(64 * 50.0, abs=0.5)


def test_only_the_window_counts_and_a_quiet_flow_decays() -> None:
    # 10 Hz for 20 s, then 20 Hz for the last 2 s: a 2 s window sees only the new rate.
    times = [i * 0.1 for i in range(201)] + [20.0 + i * 0.05 for i in range(1, 41)]
    f = flow(times)
    assert f.stats(now=22.0, window_s=2.0, started=0.0)["rate_hz"] == pytest.approx(20.0, abs=0.01)
    assert f.stats(now=22.0, window_s=10.0, started=0.0)["rate_hz"] == pytest.approx(120 / 10.0, abs=0.01)  # 80 at 10 Hz + 40 at 20 Hz in 10 s
    # Stopped at 22 s: two seconds later the 5 s window divides by the time up to now, so the rate falls
    # (the 11 at 10 Hz in [19, 20] and the 40 at 20 Hz over 5 s, not 50/3 over the time they span), and with
    # nothing left in the window it is gone.
    quiet = f.stats(now=24.0, window_s=5.0, started=0.0)
    assert quiet["rate_hz"] == pytest.approx(51 / 5.0, abs=0.01)
    gone = f.stats(now=40.0, window_s=5.0, started=0.0)
    assert gone["rate_hz"] is None and gone["bytes_per_s"] is None

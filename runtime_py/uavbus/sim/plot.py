"""demo-out/imu.png: IMU values received at the GCS over time, with the restart gap shaded."""

from __future__ import annotations

from pathlib import Path
__all__ = ["plot_series"]


def plot_series(path: str | Path, t: list[float], series: dict[str, list[float]], *, title: str,
                gaps: list[tuple[float, float, str]] | None = None, ylabel: str = "value",
                break_after: float = 0.25) -> None:
    """Line plot of `series` against `t` (seconds); each gap (start, end, label) is shaded and labelled.

    Lines are broken where no sample arrived for `break_after` seconds, so an outage shows as a hole
    rather than as a straight line across it. matplotlib is an optional dependency (the ``demo`` extra); the Agg backend needs no display.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 4.5), dpi=110)
    for name, ys in series.items():
        xs_b: list[float] = []
        ys_b: list[float] = []
        for i, (x, y) in enumerate(zip(t, ys)):
            if i and x - t[i - 1] > break_after:
                xs_b.append(float("nan"))
                ys_b.append(float("nan"))
            xs_b.append(x)
            ys_b.append(y)
        ax.plot(xs_b, ys_b, linewidth=0.9, label=name)
    for start, end, label in gaps or []:
        ax.axvspan(start, end, color="tab:red", alpha=0.15)
        ax.text((start + end) / 2, 0.98, label, transform=ax.get_xaxis_transform(), ha="center", va="top",
                fontsize=8, color="tab:red")
    ax.set_xlabel("time since start (s)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)

"""The built and installed package, made once per test session (building and installing take most of
a minute): `python -m build` from this checkout (an sdist, then a wheel from the sdist, so both must be
complete), and a fresh virtual environment outside the tree with that wheel installed by pip."""

from __future__ import annotations

import subprocess
import sys
import zipfile
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@dataclass
class Installed:
    wheel: Path
    sdist: Path
    build_log: str
    venv: Path

    @property
    def python(self) -> Path:
        return self.venv / "bin" / "python"

    @property
    def uavbus(self) -> Path:
        return self.venv / "bin" / "uavbus"

    def names(self) -> list[str]:
        with zipfile.ZipFile(self.wheel) as z:
            return z.namelist()


def _run(cmd: list[str], cwd: Path, timeout: int = 600) -> str:
    r = subprocess.run([str(c) for c in cmd], cwd=cwd, capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, f"{' '.join(map(str, cmd))} failed:\n{r.stdout[-4000:]}\n{r.stderr[-4000:]}"
    return r.stdout + r.stderr


@pytest.fixture(scope="session")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Installed:
    root = tmp_path_factory.mktemp("package")
    dist = root / "dist"
    # --no-isolation: the build requirements (setuptools, cffi) come from this environment, not from a
    # download; the sdist -> wheel path is the same as in an isolated build.
    log = _run([sys.executable, "-m", "build", "--no-isolation", "--outdir", dist, REPO], cwd=root)
    (wheel,) = dist.glob("uavbus-*.whl")
    (sdist,) = dist.glob("uavbus-*.tar.gz")
    venv = root / "venv"
    _run([sys.executable, "-m", "venv", venv], cwd=root)
    _run([venv / "bin" / "python", "-m", "pip", "install", "--disable-pip-version-check", "-q", wheel], cwd=root)
    return Installed(wheel, sdist, log, venv)

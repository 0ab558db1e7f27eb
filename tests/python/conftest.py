"""Session fixtures for the Python binding tests: catalogues generated once per session."""

from __future__ import annotations

import pytest

from binding_testutil import ALL_KINDS, FLIGHTSW, Generated, _generate


@pytest.fixture(scope="session")
def flightsw(tmp_path_factory: pytest.TempPathFactory) -> Generated:
    files = sorted(FLIGHTSW.glob("*.h"))
    return _generate(tmp_path_factory.mktemp("gen"), "flightsw", files, ["-I", str(FLIGHTSW)])


@pytest.fixture(scope="session")
def kinds(tmp_path_factory: pytest.TempPathFactory) -> Generated:
    return _generate(tmp_path_factory.mktemp("gen"), "kinds", [ALL_KINDS], ["--id-scheme", "hashed"])

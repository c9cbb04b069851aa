"""Shared fixtures: a private model cache per test session, so tests never touch ~/.cache."""

import pytest


@pytest.fixture(scope="session", autouse=True)
def _model_cache(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    mp.setenv("TANGLE_DRAKE_CACHE", str(tmp_path_factory.mktemp("cache")))
    yield
    mp.undo()

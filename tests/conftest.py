"""Shared fixtures: a private model cache per test session, so tests never touch ~/.cache;
one torch thread for the modules that train."""

import pytest


@pytest.fixture(scope="session", autouse=True)
def _model_cache(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    mp.setenv("TANGLE_DRAKE_CACHE", str(tmp_path_factory.mktemp("cache")))
    yield
    mp.undo()


@pytest.fixture(scope="module")
def one_torch_thread():
    """Two OpenMP threads on two cores shared with other jobs can run ten times slower."""
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)

"""Shared test setup."""
import pytest
import torch


@pytest.fixture(autouse=True, scope="session")
def one_torch_thread():
    """As the command-line tools do: the IK and GP tensors here are small, and on a shared 2-core
    machine two intra-op threads spin against each other (IK measured 6-50x slower)."""
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)

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


def pytest_addoption(parser):
    parser.addoption(
        "--perturb-physics", type=float, default=0.0, metavar="REL",
        help="scale every PyBullet time step by (1 + REL), e.g. 1e-9: a change below any physical "
             "meaning that finds tests which pin one machine's exact simulated trajectory",
    )


@pytest.fixture(autouse=True, scope="session")
def perturbed_physics(request):
    """With ``--perturb-physics REL``, every simulated world steps by ``dt * (1 + REL)`` (the
    simulator itself is untouched: its ``pybullet.setTimeStep`` call is wrapped for the session)."""
    relative = request.config.getoption("--perturb-physics")
    if not relative:
        yield
        return
    import pybullet

    original = pybullet.setTimeStep

    def perturbed(time_step, *args, **kwargs):
        return original(time_step * (1.0 + relative), *args, **kwargs)

    pybullet.setTimeStep = perturbed
    yield
    pybullet.setTimeStep = original


@pytest.fixture(scope="session")
def recorded_sphere_run(tmp_path_factory):
    """A 5-touch simulated run on the registry sphere (seed 0, mesh 32): its session and outputs,
    shared by the tests that replay a recorded run. Tests copy what they change."""
    from explorer.run import RunSettings, explore

    out = tmp_path_factory.mktemp("recorded-sphere")
    return explore(RunSettings(object="sphere", touches=5, seed=0, eval_every=0, mesh_resolution=32, reach_samples=0), out)

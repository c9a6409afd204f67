"""Test configuration: a non-interactive matplotlib backend, no silent pass on an empty collection, and
``--scipy-path`` to run tests with the compiled simulation path switched off (the test matrix of issue 16:
``tests/test_compiled.py`` runs the core tests that way)."""
import matplotlib

matplotlib.use("Agg")


def pytest_addoption(parser):
    parser.addoption("--scipy-path", action="store_true", default=False,
                     help="switch the compiled simulation path off: every run takes the scipy path")


def pytest_configure(config):
    if config.getoption("--scipy-path"):
        import acausal.compiled
        acausal.compiled.available = lambda: False


def pytest_report_header(config):
    if config.getoption("--scipy-path"):
        return "simulation path: scipy only (--scipy-path)"
    from acausal.compiled import available
    return "simulation path: " + ("compiled where supported (CasADi)" if available() else "scipy (no CasADi)")


def pytest_sessionfinish(session, exitstatus):
    # pytest exits with 5 when nothing was collected; make sure that can never look like success
    if session.testscollected == 0:
        session.exitstatus = 5

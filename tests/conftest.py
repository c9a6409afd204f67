"""Test configuration: a non-interactive matplotlib backend, no silent pass on an empty collection,
``--scipy-path`` to run tests with the compiled simulation path switched off (``tests/simulation/test_compiled.py`` runs the core tests
that way), and ``--whole-jobs`` for the benchmarks of whole
minute-scale commands (marked ``whole_job``: ``acausal paper`` on its full grids, ``acausal diagnose`` on 36
recordings). Those time a command against its goal and take four minutes of both cores between them; the
README's test command leaves them out (each says so as a skip), its speed section runs them."""
import matplotlib
import pytest

matplotlib.use("Agg")


def pytest_addoption(parser):
    parser.addoption("--scipy-path", action="store_true", default=False,
                     help="switch the compiled simulation path off: every run takes the scipy path")
    parser.addoption("--whole-jobs", action="store_true", default=False,
                     help="also run the benchmarks of whole minute-scale commands (marked whole_job)")


def pytest_collection_modifyitems(config, items):
    # a benchmark times a run against a reference in the same run: never in the quick lane (pytest -m "not slow")
    for item in items:
        if "benchmarks" in item.path.parts:
            item.add_marker(pytest.mark.slow)
    if config.getoption("--whole-jobs"):
        return
    skip = pytest.mark.skip(reason="a whole minute-scale command, timed against its goal: run with --whole-jobs "
                                   "(README, section Speed)")
    for item in items:
        if "whole_job" in item.keywords:
            item.add_marker(skip)


def pytest_configure(config):
    if config.getoption("--scipy-path"):
        import acausal.simulation.compiled
        acausal.simulation.compiled.available = lambda: False


def pytest_report_header(config):
    """Which accelerators this machine has and the path a default run takes (``acausal info``): a test that needs
    one it lacks skips saying so and checks the fallback instead."""
    if config.getoption("--scipy-path"):
        return "simulation path: scipy only (--scipy-path)"
    from acausal.cli.accelerators import default_path, survey
    found = survey()
    return [f"simulation path: {default_path(found)}",
            "accelerators: " + ", ".join(f"{a.name} {'yes' if a.present else 'no (' + a.found + ')'}" for a in found)]


def pytest_sessionfinish(session, exitstatus):
    # pytest exits with 5 when nothing was collected; make sure that can never look like success
    if session.testscollected == 0:
        session.exitstatus = 5

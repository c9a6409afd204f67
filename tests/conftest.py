"""Test configuration: a non-interactive matplotlib backend, and no silent pass on an empty collection."""
import matplotlib

matplotlib.use("Agg")


def pytest_sessionfinish(session, exitstatus):
    # pytest exits with 5 when nothing was collected; make sure that can never look like success
    if session.testscollected == 0:
        session.exitstatus = 5

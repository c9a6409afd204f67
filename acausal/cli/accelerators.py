"""What this machine has of the optional accelerators, and the path a default run takes with them.

Nothing here is needed for a correct answer: without any of them every run takes the scipy path, with the same
answers (the parity suite checks it). Each buys speed or an output:

* **CasADi** (``pip install "acausal[fast]"``): the compiled path, the model's equations as CasADi expressions
  integrated by SUNDIALS CVODES/IDAS in compiled code;
* **a C compiler** (``$CC``, else ``cc``, ``gcc``, ``clang``): the fixed-step servo replays in C, FMU binaries;
* **SUNDIALS's headers and libraries** (6.x; Debian: ``apt-get install libsundials-dev``), with CasADi and a C
  compiler: the native loop (:mod:`acausal.simulation.compiled.native_loop`), every compiled-path run integrated in C
  without CasADi's virtual machine around the steps; ``ACAUSAL_NATIVE=0`` switches it off;
* **plotly** (``pip install "acausal[html]"``): the HTML pages (``Result.to_html``, ``acausal paper``'s
  ``index.html``, ``acausal compare --html``);
* **Chromium and chromedriver** (Debian: ``apt-get install chromium chromium-driver``): only the test that opens
  the explorer page in a browser.

:func:`survey` looks each up (the native loop by building it: once per machine, a second or so of the compiler,
then cached) and :func:`default_path` says which path a default ``simulate()`` takes; ``acausal info`` prints both.
"""
from __future__ import annotations

import importlib.util
import os
import shutil
import sys
from dataclasses import dataclass

#: Chromium's binary under the names Debian and others give it
BROWSERS = ("chromium", "chromium-browser", "google-chrome")


@dataclass(frozen=True)
class Accelerator:
    """One optional accelerator: whether it is present here, what was found (a version, a path) or why it is not,
    what it buys and how to get it."""

    name: str
    present: bool
    found: str
    buys: str
    get: str


def _package(name: str, module: str, buys: str, get: str) -> Accelerator:
    """An optional Python package: present where it is importable, found as its version."""
    present = importlib.util.find_spec(module) is not None
    if not present:
        return Accelerator(name, False, "not installed", buys, get)
    from importlib.metadata import version
    return Accelerator(name, True, f"{module} {version(module)}", buys, get)


def casadi() -> Accelerator:
    return _package("CasADi", "casadi", "the compiled path: SUNDIALS CVODES/IDAS in compiled code",
                    'pip install "acausal[fast]"')


def compiler() -> Accelerator:
    from ..backends.ccompiler import which_compiler
    cc = which_compiler()[0]
    found = cc if cc else ("$CC names none that exists" if os.environ.get("CC") else "none of cc, gcc, clang found")
    return Accelerator("C compiler", cc is not None, found, "servo replays' fixed steps in C; FMU binaries",
                       "a C compiler on PATH or in $CC (Debian: apt-get install gcc)")


def native_loop() -> Accelerator:
    """The native loop: present where it is switched on, CasADi is installed and ``native_dae.c`` builds against
    SUNDIALS (built here if it is not in the library cache yet)."""
    get = "apt-get install libsundials-dev (Debian; SUNDIALS 6.x), with CasADi and a C compiler"
    buys = "every compiled-path run integrated in C, without CasADi's machinery around the steps"
    from ..simulation.compiled import available
    from ..simulation.compiled.native_loop import _loop, why_off
    off = why_off()
    if off is not None:
        return Accelerator("native loop", False, off, buys, "unset ACAUSAL_NATIVE" if "ACAUSAL_NATIVE" in off else get)
    if not available():
        return Accelerator("native loop", False, "needs CasADi, not installed", buys, get)
    loop, why = _loop()
    if loop is None:
        text = str(why)
        if "sundials" in text.lower() or "idas" in text or "cvodes" in text:
            text = "SUNDIALS's headers or libraries not found"
        return Accelerator("native loop", False, text.splitlines()[0][:160], buys, get)
    return Accelerator("native loop", True, "built against SUNDIALS", buys, get)


def plotly() -> Accelerator:
    return _package("plotly", "plotly", "HTML pages (Result.to_html, acausal paper's index.html)",
                    'pip install "acausal[html]"')


def browser_and_driver() -> tuple:
    """``(Chromium's binary or None, chromedriver or None)`` as found on the PATH."""
    return next((shutil.which(b) for b in BROWSERS if shutil.which(b)), None), shutil.which("chromedriver")


def browser() -> Accelerator:
    binary, driver = browser_and_driver()
    missing = [n for n, f in (("chromium", binary), ("chromedriver", driver)) if f is None]
    found = f"{binary}, {driver}" if not missing else f"no {' and '.join(missing)}"
    return Accelerator("Chromium", not missing, found, "only the test that opens the explorer page in a browser",
                       "apt-get install chromium chromium-driver (Debian)")


def survey() -> list[Accelerator]:
    """Every optional accelerator, looked up now."""
    return [casadi(), compiler(), native_loop(), plotly(), browser()]


def default_path(accelerators: list[Accelerator] | None = None) -> str:
    """The path a default ``simulate()`` of a model the compiled path supports takes on this machine."""
    have = {a.name: a.present for a in (accelerators or survey())}
    if have["native loop"]:
        return "the compiled path on the native loop (SUNDIALS CVODES/IDAS in C)"
    if have["CasADi"]:
        return "the compiled path on CasADi's integrators (SUNDIALS CVODES/IDAS through CasADi)"
    return "the scipy path (LSODA; BDF for a model with state events)"


def describe() -> str:
    """The text of ``acausal info``: versions, each accelerator and the default path."""
    from importlib.metadata import version

    from .. import __version__
    import numpy
    import scipy

    accelerators = survey()
    lines = [f"acausal {__version__} on Python {sys.version.split()[0]} ({sys.platform}); numpy {numpy.__version__}, "
             f"scipy {scipy.__version__}, sympy {version('sympy')}",
             f"a default run takes {default_path(accelerators)}", "", "optional accelerators:"]
    for a in accelerators:
        lines.append(f"  [{'x' if a.present else ' '}] {a.name:<12} {a.found}")
        lines.append(f"      {'buys' if a.present else 'would buy'}: {a.buys}")
        if not a.present:
            lines.append(f"      get it: {a.get}")
    from ..backends.ccompiler import cache_dir
    lines += ["", f"library cache: {cache_dir()} (ACAUSAL_CACHE_DIR moves it)"]
    return "\n".join(lines)

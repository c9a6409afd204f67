"""The package as a user installs it: a wheel built from a clean copy of the checkout (its tracked files and the new
ones git does not ignore: what a commit of the work tree would hold), installed into a fresh virtual environment
outside the checkout, and its commands run from a folder outside it too.

The wheel is installed without its dependencies (``--no-deps --no-index``: no network at test time); the fresh
environment borrows the running one's site folders for numpy, scipy, CasADi and the rest through a ``.pth`` file.
A ``.pth`` line only adds a folder to ``sys.path``, it runs none of the ``.pth`` files in it, so an editable
install of acausal in the running environment stays inactive there: ``acausal`` is imported from the wheel, which
:func:`installed_wheel` asserts. ``.ci/run`` installs the same wheel once more with its dependencies from the
package index and runs the full ``acausal paper`` with it.
"""
from __future__ import annotations

import os
import shutil
import site
import subprocess
import sys
import sysconfig
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent.parent


@dataclass(frozen=True)
class Installed:
    """A fresh environment holding the wheel: its interpreter, its ``acausal`` script and a working folder
    outside the checkout."""

    python: Path
    script: Path
    workdir: Path

    def run(self, *args, timeout: float = 900) -> subprocess.CompletedProcess:
        """``acausal ARGS`` from the working folder; the completed process (stdout, stderr as text)."""
        return subprocess.run([str(self.script), *args], cwd=self.workdir, capture_output=True, text=True,
                              timeout=timeout)


def clean_copy(dest: Path) -> Path:
    """The checkout's tracked and not-ignored files copied to ``dest`` (the tree as a clean clone would have it)."""
    listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                            capture_output=True, check=True).stdout.decode().split("\0")
    for rel in filter(None, listed):
        src = ROOT / rel
        if src.is_file():
            (dest / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / rel)
    return dest


def build_wheel(tmp: Path) -> Path:
    """The wheel of a clean copy of the checkout, built without network (the running environment's setuptools)."""
    src = clean_copy(tmp / "src")
    dist = tmp / "dist"
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--no-index",
                           "-w", str(dist), str(src)], capture_output=True, text=True)
    assert proc.returncode == 0, f"the wheel did not build:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    (wheel,) = dist.glob("acausal-*.whl")
    return wheel


def installed_wheel(tmp: Path) -> Installed:
    """Build the wheel and install it into a fresh environment under ``tmp`` (see the module)."""
    wheel = build_wheel(tmp)
    venv = tmp / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, capture_output=True)
    bindir = venv / ("Scripts" if os.name == "nt" else "bin")
    python = bindir / ("python.exe" if os.name == "nt" else "python")
    purelib = Path(subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                                  capture_output=True, text=True, check=True).stdout.strip())
    borrowed = dict.fromkeys([sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"],
                              *site.getsitepackages()])
    (purelib / "_acausal_test_borrowed.pth").write_text("".join(f"{p}\n" for p in borrowed))
    proc = subprocess.run([str(python), "-m", "pip", "install", "--quiet", "--no-deps", "--no-index", str(wheel)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, f"the wheel did not install:\n{proc.stderr[-3000:]}"
    work = tmp / "elsewhere"
    work.mkdir()
    where = subprocess.run([str(python), "-c", "import acausal, acausal.models, acausal.library; "
                            "print(acausal.__file__)"], cwd=work, capture_output=True, text=True)
    assert where.returncode == 0, where.stderr[-3000:]
    origin = Path(where.stdout.strip())
    assert origin.is_relative_to(venv) and not origin.is_relative_to(ROOT), origin
    return Installed(python, bindir / "acausal", work)

"""``export_fmu``: a compiled model as an FMI 2.0 Model Exchange FMU (a zip: ``modelDescription.xml``, the binary
``binaries/linux64/<id>.so`` built from generated C, that C in ``sources/`` and ``documentation/index.html``).
"""
from __future__ import annotations

import hashlib
import inspect
import os
import platform
import re
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

from ..backends.ccompiler import COMPILERS, library_form, which_compiler
from . import ccode
from .ccode import ExportError
from .model_description import documentation, model_description

#: optimisation: -O1 compiles the generated functions about twice as fast as -O2 (closed-loop actuator: 0.26 s
#: against 0.52 s); the importing tool's integrator, not the model's arithmetic, dominates an FMU's run time
CFLAGS = ("-O1", "-fPIC", "-fvisibility=hidden", "-std=c99")


def platform_folder() -> tuple:
    """``(FMI platform folder, shared library suffix, link flags)`` of this machine; an ExportError elsewhere."""
    bits64 = sys.maxsize > 2**32
    machine = platform.machine().lower()
    suffix, link = library_form()
    if sys.platform.startswith("linux") and bits64 and machine in ("x86_64", "amd64", "aarch64", "arm64"):
        return "linux64", suffix, link
    if sys.platform == "darwin" and bits64:
        return "darwin64", suffix, link
    raise ExportError(f"export_fmu builds binaries on 64-bit Linux and macOS only (this is {sys.platform} "
                      f"{machine}); export with binary=False for a source FMU and let the importing tool compile "
                      "sources/")


#: what to do without a compiler, in the words of the Python call (the command line passes its own options')
REMEDY = "name it with compiler= or CC, or export with binary=False for a source-only FMU"


def find_compiler(compiler: str | None = None, remedy: str = REMEDY) -> str:
    """The C compiler to use (:func:`acausal.backends.ccompiler.which_compiler`: ``compiler``, else ``$CC``, else the
    first of its list on the PATH); an :class:`ExportError` saying what to install and ``remedy`` when there is
    none."""
    found, origin = which_compiler(compiler)
    if found:
        return found
    if origin:
        raise ExportError(f"the C compiler {compiler or os.environ.get('CC')!r} ({origin}) was not found on the PATH; "
                          + remedy)
    raise ExportError("no C compiler found (looked for $CC, " + ", ".join(COMPILERS) + " on the PATH): an FMU's "
                      "binary is compiled from generated C. Install one (Debian/Ubuntu: apt-get install gcc; "
                      "Fedora: dnf install gcc; macOS: xcode-select --install), " + remedy)


def compiler_fault(cc: str, given: str | None, tmp: Path) -> str | None:
    """Why ``cc`` is not a working C compiler (it cannot build a one-line program), naming where it came from
    (``compiler=``/``--compiler``, ``$CC`` or the PATH); None when it is one (then the generated code is at fault)."""
    probe = tmp / "probe.c"
    probe.write_text("int main(void) { return 0; }\n")
    try:
        run = subprocess.run([cc, "-o", str(tmp / "probe"), str(probe)], capture_output=True, text=True, timeout=120)
    except (OSError, subprocess.SubprocessError) as exc:
        code, said = None, str(exc)
    else:
        if run.returncode == 0:
            return None
        code, said = run.returncode, (run.stderr or run.stdout).strip()
    origin = "compiler= (--compiler)" if given else "$CC" if os.environ.get("CC") else "found on the PATH"
    return (f"the C compiler {cc} ({origin}) cannot build a one-line C program"
            + (f" (exit status {code})" if code is not None else "") + (f": {said[-800:]}" if said else
                                                                         " and says nothing")
            + ": is it a C compiler? Name a working one with --compiler or CC")


def own_doc(cls) -> str:
    """``cls``'s own docstring, cleaned (not one inherited from :class:`~acausal.Model`, the framework's); "" when
    it has none: the FMU's description."""
    text = cls.__dict__.get("__doc__")
    return inspect.cleandoc(text) if isinstance(text, str) else ""


def identifier_of(name: str) -> str:
    """A C identifier from a model name (the FMU's ``modelIdentifier`` and the binary's file name)."""
    ident = re.sub(r"\W", "_", name, flags=re.ASCII)
    return ident if re.match(r"[A-Za-z_]", ident) else f"model_{ident}"


def export_fmu(model, path, *, params: dict | None = None, inputs: dict | None = None, doc: str | None = None,
               identifier: str | None = None, binary: bool = True, compiler: str | None = None,
               stop_time: float | None = None) -> Path:
    """Write ``model`` (a :class:`~acausal.CompiledModel`, or a :class:`~acausal.Model` instance, compiled here) as
    an FMI 2.0 Model Exchange FMU to ``path`` and return the path.

    ``params``: parameter values by name [SI units] that become the FMU's start values (default: the model's
    defaults); every parameter stays settable through FMI before ``fmi2ExitInitializationMode``. ``inputs``:
    replacement signals for numeric inputs, as in :meth:`simulate`. Numeric inputs are compiled in (tables or
    expressions); an input rebuilt from parameters (a :class:`~acausal.model.signals.ParametricSignal`, e.g. a planned
    trajectory) is built once with the export's parameter values, and setting those parameters in the FMU does
    not rebuild it (the FMU logs a warning; the documentation and the parameters' descriptions say so).
    ``doc``: the model's documentation (default: the docstring of the model's class when a Model is given).
    ``identifier``: the ``modelIdentifier`` (default: the model's class name). ``binary=False`` writes a
    source-only FMU (no compiler needed). ``compiler``: the C compiler (default ``$CC``, then cc, gcc, clang).
    ``stop_time`` [s]: the DefaultExperiment's stop time (none by default).

    Raises :class:`ExportError` (a ModelError) naming what is missing: an input without a table or symbolic form,
    an unknown parameter, no C compiler (with what to install), a platform without binary support.
    """
    from .. import __version__
    from ..compiled_model import CompiledModel, compile_model
    from ..model.components import Component

    if isinstance(model, CompiledModel):
        cm = model
    elif isinstance(model, Component):
        cm = compile_model(model)
        if doc is None:
            doc = own_doc(type(model))
    else:
        raise ExportError(f"export_fmu: expected a CompiledModel or a Model instance, got {type(model).__name__}")
    path = Path(path)
    if path.suffix.lower() != ".fmu":
        raise ExportError(f"export_fmu: the file name {str(path)!r} must end in .fmu")
    if identifier is not None and not (isinstance(identifier, str) and identifier.isidentifier()
                                       and identifier.isascii()):
        raise ExportError(f"export_fmu: identifier {identifier!r} is not a C identifier (ASCII letters, digits and "
                          f"_, not starting with a digit), e.g. {identifier_of(str(identifier))!r}")
    ident = identifier_of(identifier or cm.flat.name)
    doc = (doc or "").strip()
    description = doc.split("\n\n")[0].replace("\n", " ") if doc else f"{cm.flat.name} (exported by acausal)"
    # what the model cannot be as an FMU is said before what the machine lacks to build one
    head, tail, layout, tabulated, start = ccode.generate(cm, ident, "{GUID}", params=params, inputs=inputs)
    folder, suffix, link = platform_folder() if binary else (None, None, None)
    cc = find_compiler(compiler) if binary else None
    fixed = {s for s in layout.states if getattr(cm.flat.variables.get(s), "fixed", False)}
    has_targets = any(v.fixed and n not in layout.states for n, v in cm.flat.variables.items()) or \
        bool(getattr(cm.flat, "fixed_constants", {}))
    adjusted = {s for s in layout.states if s not in fixed} if has_targets else set()
    source_name = f"{ident}.c"

    def describe(guid):
        return model_description(cm, layout, start, tabulated, identifier=ident, guid=guid, description=description,
                                 source_file=source_name, version=__version__, adjusted=adjusted,
                                 stop_time=stop_time)

    digest = hashlib.sha256((describe("") + head + tail).encode()).hexdigest()
    guid = "{" + "-".join((digest[:8], digest[8:12], digest[12:16], digest[16:20], digest[20:32])) + "}"
    head = head.replace('"{GUID}"', f'"{guid}"')
    c_text = ccode.source(head, tail)
    xml = describe(guid)
    html = documentation(cm, layout, start, tabulated, description=description, doc=doc, identifier=ident,
                         adjusted=adjusted)
    with tempfile.TemporaryDirectory(prefix="acausal_fmu_") as tmp:
        members = {"modelDescription.xml": xml.encode(), f"sources/{source_name}": c_text.encode(),
                   "documentation/index.html": html.encode()}
        if binary:
            c_file = Path(tmp) / source_name
            c_file.write_text(c_text)
            lib = Path(tmp) / f"{ident}{suffix}"
            cmd = [cc, *link, *CFLAGS, "-o", str(lib), str(c_file), "-lm"]
            run = subprocess.run(cmd, capture_output=True, text=True)
            if run.returncode != 0:
                broken = compiler_fault(cc, compiler, Path(tmp))
                if broken:
                    raise ExportError(broken)
                raise ExportError(f"the C compiler {cc} failed on the generated code of {cm.flat.name} (a bug of "
                                  f"the exporter: please report it with the model):\n{run.stderr[-4000:]}")
            members[f"binaries/{folder}/{ident}{suffix}"] = lib.read_bytes()
        path.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
            for name, data in members.items():
                zf.writestr(name, data)
    return path

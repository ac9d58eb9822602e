"""What every module of rwg's JAX worker shares: the fault bits of an episode,
failures raised by Python or XLA reported through the pipe, and the versions of
installed distributions."""

from rwg_pipe import fail

import traceback

FAULT_OBS = 1
FAULT_REWARD = 2
FAULT_RETURN = 4  # with non_finite = "end": the return left +-MAX_RETURN
MAX_RETURN = 1e100  # rwg_core's bound on an episode's return


def fail_exc(kind, what, e):
    """fail() for the exception `e` raised while doing `what`; an XLA
    RESOURCE_EXHAUSTED becomes `oom` with what to do."""
    lines = str(e).strip().splitlines()
    # one line: the whole text is in the traceback
    text = f"{type(e).__name__}: {lines[0] if lines else ''}{' ...' if len(lines) > 1 else ''}"
    if "RESOURCE_EXHAUSTED" in text or "out of memory" in text.lower():
        fail("oom", f"{what} ran out of device memory ({text.splitlines()[0]}); lower "
                    f"networks_per_call in the manifest's [[envs]] entry", traceback.format_exc())
    fail(kind, f"{what} raised {text}", traceback.format_exc())


def version_of(dist):
    import importlib.metadata

    try:
        return importlib.metadata.version(dist)
    except BaseException:  # noqa: BLE001 -- not an installed distribution
        return None


def import_family(module, package, what):
    """`import module`, or a failure that tells a package that is not
    installed (`pip install package`) from one that is installed but fails to
    import (the import's own reason, e.g. a dependency it does not declare)."""
    import importlib
    import importlib.util
    import sys

    try:
        return importlib.import_module(module)
    except BaseException as e:  # noqa: BLE001 -- any failure of the import is reported
        err = e
    top = module.split(".")[0]
    try:
        installed = importlib.util.find_spec(top) is not None
    except BaseException:  # noqa: BLE001
        installed = False
    missing = getattr(err, "name", None) if isinstance(err, ImportError) else None
    text = f"{type(err).__name__}: {err}"
    if not installed:
        fail("import", f"{what} is not installed for {sys.executable} ({text}); install it with "
                       f"`{sys.executable} -m pip install {package}`", traceback.format_exc())
    hint = ""
    if missing and missing.split(".")[0] != top:
        hint = (f"; it needs the module {missing!r}, which is missing: install the package that "
                f"provides it (often `{sys.executable} -m pip install {missing.split('.')[0]}`)")
    fail("import", f"{what} is installed for {sys.executable} but importing {module} failed: "
                   f"{text}{hint}", traceback.format_exc())

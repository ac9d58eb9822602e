"""What every module of rwg's JAX worker shares: the fault bits of an episode,
failures raised by Python or XLA reported through the pipe, and the versions of
installed distributions."""

from rwg_pipe import fail

import traceback

FAULT_OBS = 1
FAULT_REWARD = 2


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

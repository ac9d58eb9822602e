"""rwg_pipe: the pipe to rwg, shared by rwg's Python workers (the Gymnasium
bridge's worker.py and rwg-jax's jax_worker.py), which import it first.

Importing it takes private duplicates of the original stdin/stdout for the
protocol and sends fd 1 to stderr and fd 0 to /dev/null (so whatever the env
prints goes to stderr), ignores SIGINT, ends with rwg even when started
through a wrapper, and makes faulthandler dump the stacks on a fault or on
SIGUSR1. Its functions frame the messages of
docs/bridge-protocol.md: a 4-byte little-endian length (of the tag and
payload), a 1-byte tag, the payload.
"""

import os
import sys

# --- protocol channels: private copies of fd 0/1, then fd 1 -> stderr, fd 0 -> /dev/null
in_fd = os.dup(0)
out_fd = os.dup(1)
os.dup2(2, 1)
_null = os.open(os.devnull, os.O_RDONLY)
os.dup2(_null, 0)
os.close(_null)
sys.stdout = sys.stderr

import faulthandler  # noqa: E402
import json  # noqa: E402
import signal  # noqa: E402
import struct  # noqa: E402

# rwg starts each worker in a process group of its own (killed with it), so
# Ctrl-C on a terminal reaches rwg alone; a SIGINT sent to the worker's group
# is ignored too: rwg stops after the work in flight and then closes the
# pipes (as with rwg's own plugin workers), not a KeyboardInterrupt.
signal.signal(signal.SIGINT, signal.SIG_IGN)


def _end_with_rwg():
    """On Linux rwg starts each worker with a death signal (SIGKILL when rwg
    ends, however it ends). A worker started through a wrapper that runs
    Python as its child instead of exec-ing it (a shell script that sets up
    modules, say) is rwg's grandchild: the death signal kills the wrapper and
    would leave this process computing on. It ties itself to the wrapper
    (PR_SET_PDEATHSIG), and quits if rwg is gone already."""
    try:
        rwg = int(os.environ.get("RWG_WORKER_FAMILY", "").split(":")[0])
    except ValueError:
        return
    wrapper = os.getppid()
    if not sys.platform.startswith("linux") or wrapper == rwg:
        return
    import ctypes

    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
        if os.getppid() != wrapper:
            os._exit(1)  # the wrapper ended before the death signal was set
        os.kill(rwg, 0)
    except ProcessLookupError:
        os._exit(1)
    except (OSError, AttributeError):
        pass


_end_with_rwg()

faulthandler.enable(file=sys.stderr)
if hasattr(faulthandler, "register"):
    # rwg sends SIGUSR1 to a worker that does not answer in time, to learn where it hangs.
    faulthandler.register(signal.SIGUSR1, file=sys.stderr, all_threads=True)

# A message's head: the length of tag and payload, and the tag.
HEAD = struct.Struct("<IB")


def read_exact(n):
    buf = bytearray(n)
    view = memoryview(buf)
    got = 0
    while got < n:
        k = os.readv(in_fd, [view[got:]])
        if k == 0:
            sys.exit(0)  # rwg closed the pipe: quit quietly
        got += k
    return buf


def read_msg():
    length, tag = HEAD.unpack(read_exact(5))
    return tag, read_exact(length - 1)


def write_msg(tag, *parts):
    n = 1 + sum(len(p) for p in parts)
    data = b"".join((HEAD.pack(n, tag),) + parts)
    view = memoryview(data)
    while view:
        k = os.write(out_fd, view)
        view = view[k:]


def send_json(tag, obj):
    write_msg(tag, json.dumps(obj, allow_nan=False).encode())


def progress(kind):
    """While starting: tells rwg what comes next (a one-byte kind; each
    worker's docs say which kinds it sends and which timeout each gets)."""
    write_msg(ord("P"), kind)


def fail(kind, message, tb=None):
    send_json(ord("E"), {"kind": kind, "message": message, "traceback": tb or ""})
    sys.exit(0)


def floats(a):
    """A list of floats for JSON, infinities as the strings "inf"/"-inf"."""
    out = []
    for v in a:
        v = float(v)
        if v == float("inf"):
            out.append("inf")
        elif v == float("-inf"):
            out.append("-inf")
        elif v != v:
            out.append("nan")
        else:
            out.append(v)
    return out


KWARG_TAG = "$rwg"
_KWARG_FLOATS = {"nan": float("nan"), "inf": float("inf"), "-inf": float("-inf")}


def decode_kwargs(v):
    """Keyword arguments (of gym.make, or of a JAX env's maker) from the
    hello's JSON, which has no nan/inf: an object whose only key is "$rwg"
    holds "nan", "inf" or "-inf" (that float) or an object (the user's own
    object of that one key)."""
    if isinstance(v, dict):
        if len(v) == 1 and KWARG_TAG in v:
            x = v[KWARG_TAG]
            if isinstance(x, str) and x in _KWARG_FLOATS:
                return _KWARG_FLOATS[x]
            if isinstance(x, dict):
                return {k: decode_kwargs(y) for k, y in x.items()}
            fail("protocol", f"kwargs: {v!r} is not a value rwg encodes")
        return {k: decode_kwargs(y) for k, y in v.items()}
    if isinstance(v, list):
        return [decode_kwargs(y) for y in v]
    return v


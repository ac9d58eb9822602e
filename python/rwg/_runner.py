"""``rwg.run``: a study run by the ``rwg`` binary, from Python."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
from typing import IO, Any, List, Mapping, Optional, Union

from . import _args, _toml
from ._binary import find_rwg_bin, start_error
from ._rundir import Run, load, tomllib
from .errors import ArgumentError, RwgFailedError

#: The overrides ``run`` takes, and the ``rwg run`` flag each becomes
#: (``True`` for the flags without a value).
VALUE_FLAGS = {
    "samples": "--samples",
    "episodes": "--episodes",
    "seed": "--seed",
    "threads": "--threads",
    "step_timeout": "--step-timeout",
}
SWITCHES = {
    "force_new": "--force-new",
    "isolate": "--isolate",
    "no_report": "--no-report",
    "quiet": "--quiet",
    "timing": "--timing",
}
#: Lines of rwg's stderr given in the exception when it has no ``error:`` line.
_TAIL = 40


def run(
    manifest: Union[str, "os.PathLike[str]", Mapping[str, Any]],
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
    **overrides: Any,
) -> Run:
    """Runs the study ``manifest`` with the ``rwg`` binary and returns the
    finished :class:`Run`.

    ``manifest`` is the path of a TOML manifest, or the manifest as a dict
    (written as TOML for rwg; relative ``plugin`` and ``python`` paths in it
    are taken from the current directory). ``out`` is the run directory
    (default: the manifest's ``out``, else ``runs/NAME`` for ``NAME.toml``; a
    dict needs one of them). ``overrides`` are ``rwg run``'s options:
    ``samples``, ``episodes``, ``seed``, ``threads``, ``step_timeout`` take a
    value; ``force_new``, ``isolate``, ``no_report``, ``quiet``, ``timing``
    are switches (``True`` to give them).

    rwg's summary goes to ``sys.stdout``; its progress and messages to the
    terminal (its progress bar, through a pseudo-terminal) when stderr is one,
    else to ``sys.stderr`` (a progress line every 5 s).
    A directory holding the unfinished study is resumed. ``gymnasium:`` envs
    run in this interpreter (``RWG_PYTHON`` is set to ``sys.executable``
    unless it is set already; a manifest's ``python`` wins over both).
    Ctrl-C (SIGINT, raised in any thread) stops rwg as in a shell: it
    finishes the blocks in flight, keeps every committed block, and
    ``KeyboardInterrupt`` is raised once it has exited; calling ``run`` again
    resumes. An interrupt that comes after rwg finished returns the finished
    run. A failure raises :class:`RwgFailedError` with rwg's message; a bad
    argument :class:`ArgumentError` before anything runs. Paths are ``str``,
    ``bytes`` or ``os.PathLike``; the value options take whole numbers
    (numpy integers too).
    """
    where = "rwg.run"
    flags = _flags(overrides)
    if out is not None:
        out = _args.path(out, "out=", where)
    if not isinstance(manifest, Mapping):
        manifest = _args.path(
            manifest, "manifest=", where, "the path of a TOML manifest or a dict"
        )
    rwg = find_rwg_bin()
    with tempfile.TemporaryDirectory(prefix="rwg-manifest-") as tmp:
        manifest_text: Optional[str] = None
        if isinstance(manifest, Mapping):
            doc = _absolute_paths(manifest)
            if doc.get("out") is None:
                doc.pop("out", None)  # None: no out, as an absent key
            else:
                doc["out"] = _args.path(doc["out"], "the dict's 'out' key", where)
            if out is None:
                if doc.get("out") is None:
                    raise ArgumentError(
                        "rwg.run: a manifest given as a dict needs a run directory: "
                        "pass out=... or give the dict an 'out' key"
                    )
                out = doc["out"]
            manifest_text = _toml.dumps(doc)
            # named after the run directory, as rwg's messages name the file
            name = os.path.basename(os.path.normpath(out)) or "study"
            path = os.path.join(tmp, name + ".toml")
            with open(path, "w", encoding="utf-8") as f:
                f.write(manifest_text)
        else:
            path = manifest
            if out is None:
                out = _default_out(path)
        cmd = [rwg, "run", _args.command_path(path), "--out", _args.command_path(out)] + flags
        _run_child(cmd, manifest_text)
    return load(out)


def _flags(overrides: Mapping[str, Any]) -> List[str]:
    flags: List[str] = []
    where = "rwg.run"
    for key, value in overrides.items():
        if key in VALUE_FLAGS:
            if value is None:
                continue
            flags += [VALUE_FLAGS[key], str(_args.whole(value, key, where))]
        elif key in SWITCHES:
            if _args.flag(value, key, where):
                flags.append(SWITCHES[key])
        elif key == "shard":
            raise ArgumentError(
                "rwg.run: shards are not run from Python (the result is not a whole run); run "
                "`rwg run MANIFEST --shard K/N --out DIR` per shard, `rwg merge`, then rwg.load"
            )
        else:
            known = ", ".join(sorted(list(VALUE_FLAGS) + list(SWITCHES)))
            raise ArgumentError(f"rwg.run: unknown option {key}=; the options are out, {known}")
    return flags


def _default_out(manifest_path: str) -> str:
    """The run directory rwg picks for a manifest file without --out."""
    try:
        with open(manifest_path, "rb") as f:
            out = tomllib.load(f).get("out")
    except (OSError, tomllib.TOMLDecodeError):
        out = None  # rwg itself reports the file
    if isinstance(out, str):
        return out
    stem = os.path.splitext(os.path.basename(manifest_path))[0]
    return os.path.join("runs", stem)


def _absolute_paths(manifest: Mapping[str, Any]) -> dict:
    """A copy of ``manifest`` whose relative ``plugin`` paths (and ``python``
    paths with a ``/``) in ``envs`` are made absolute from the current
    directory, since the TOML file is written elsewhere."""
    doc = dict(manifest)
    envs = doc.get("envs")
    if isinstance(envs, (list, tuple)):
        fixed = []
        for e in envs:
            if isinstance(e, Mapping):
                e = dict(e)
                p = e.get("plugin")
                if isinstance(p, (str, os.PathLike)) and not os.path.isabs(p):
                    e["plugin"] = os.path.abspath(p)
                py = e.get("python")
                if isinstance(py, (str, os.PathLike)):
                    py = os.fspath(py)
                    if "/" in py and not os.path.isabs(py):
                        e["python"] = os.path.abspath(py)
            fixed.append(e)
        doc["envs"] = fixed
    return doc


def _forward(
    src: IO[bytes], dst_name: str, keep: Optional[List[str]], held: Optional[List[bytes]] = None
) -> None:
    """Copies the child's output line by line to ``sys.stdout``/``sys.stderr``
    (looked up per line: notebooks and test harnesses swap them); with
    ``keep``, also gathers its lines there. With ``held``, rwg's message
    (its lines from the first ``error:`` on) is held there instead of
    copied: it is the message of the exception raised, shown once."""
    for raw in iter(src.readline, b""):
        text = raw.decode("utf-8", "replace")
        if held is not None and (held or text.startswith("error:")):
            held.append(raw)
        else:
            _write_to(dst_name, text)
        if keep is not None:
            keep.append(text.rstrip("\r\n"))
    src.close()


def _write_to(dst_name: str, text: str) -> None:
    """Writes ``text`` to ``sys.stdout`` or ``sys.stderr`` as it is now. The
    copying goes on whatever the stream does (``None`` under pythonw, a
    closed file, a broken notebook stream): a copy that stopped would leave
    rwg blocked on a full pipe."""
    dst = getattr(sys, dst_name, None)
    if dst is None:
        return
    try:
        dst.write(text)
        dst.flush()
    except Exception:  # noqa: BLE001 - any stream's failure; the line is kept for errors
        pass


_ANSI = re.compile(rb"\x1b\[[0-9;?]*[A-Za-z]")


def _plain_line(raw: bytes) -> str:
    """A line as a terminal shows it: escape sequences dropped, and of the
    text redrawn after carriage returns, the last."""
    parts = [p for p in _ANSI.sub(b"", raw).split(b"\r") if p.strip()]
    return parts[-1].decode("utf-8", "replace") if parts else ""


def _terminal_stderr() -> bool:
    """Whether this process's stderr is a terminal at fd 2 (POSIX)."""
    if os.name != "posix":
        return False
    try:
        return sys.stderr.isatty() and sys.stderr.fileno() == 2
    except (AttributeError, ValueError, OSError):
        return False


def _forward_pty(master: int, keep: List[str], held: List[bytes]) -> None:
    """Copies what rwg writes to its terminal (a pseudo-terminal) to this
    process's terminal as it is (progress bar included), and gathers its
    lines as they read. rwg's message, from the ``error:`` that starts a
    line on, is held in ``held`` instead (the exception's message)."""
    pending = b""  # the line being written, up to what was shown
    while True:
        try:
            chunk = os.read(master, 1 << 16)
        except OSError:  # EIO: every writer closed its end
            break
        if not chunk:
            break
        if held:
            held.append(chunk)
            continue
        data = pending + chunk
        cut = _error_start(data)
        if cut >= 0:
            held.append(data[cut:])
            chunk, data = data[len(pending):cut] if cut > len(pending) else b"", data[:cut]
        try:
            if chunk:
                os.write(2, chunk)
        except OSError:
            pass
        *complete, pending = data.split(b"\n")
        keep.extend(_plain_line(raw) for raw in complete)
    rest = pending + b"".join(held)
    keep.extend(_plain_line(raw) for raw in rest.split(b"\n") if _plain_line(raw))
    os.close(master)


def _error_start(data: bytes) -> int:
    """Where the text ``error:`` starts a line of ``data`` as a terminal
    shows it (after a carriage return and escape sequences only), or -1."""
    start = 0
    while start <= len(data):
        end = data.find(b"\n", start)
        line = data[start:] if end < 0 else data[start:end]
        at = line.find(b"error:")
        if at >= 0 and not _ANSI.sub(b"", line[:at].split(b"\r")[-1]).strip():
            return start + at
        if end < 0:
            return -1
        start = end + 1
    return -1


def _error_message(lines: List[str]) -> str:
    """rwg's message: its lines from the first ``error:`` on, without progress
    lines (``[0:00:05] ...``); else its last lines."""
    for i, line in enumerate(lines):
        if line.startswith("error:"):
            return "\n".join(x for x in lines[i:] if not x.startswith("[")).strip()
    return "\n".join(lines[-_TAIL:]).strip()


def _run_child(cmd: List[str], manifest_text: Optional[str]) -> None:
    env = dict(os.environ)
    env.setdefault("RWG_PYTHON", sys.executable)
    lines: List[str] = []
    # A session of its own: a Ctrl-C at the terminal reaches this process
    # only, which forwards it once (twice would make rwg quit at once,
    # without the blocks in flight).
    # On a terminal, rwg's stderr is a pseudo-terminal of the same size, so
    # it draws its progress bar there, and its lines are still read for the
    # error message; elsewhere (a notebook, a pipe, a log) a pipe, and rwg
    # writes a progress line every 5 s.
    master: Optional[int] = None
    stderr: Any = subprocess.PIPE
    if _terminal_stderr():
        import fcntl
        import pty
        import termios

        master, stderr = pty.openpty()
        try:
            size = fcntl.ioctl(2, termios.TIOCGWINSZ, b"\0" * 8)
            fcntl.ioctl(stderr, termios.TIOCSWINSZ, size)
        except OSError:
            pass
        _flush_stderr()
    try:
        proc = subprocess.Popen(
            cmd,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=stderr,
            env=env,
            start_new_session=True,
            preexec_fn=_die_with(os.getpid()) if sys.platform.startswith("linux") else None,
        )
    except OSError as e:
        if master is not None:
            os.close(master)
        raise start_error(cmd[0], e) from e
    except BaseException:
        if master is not None:
            os.close(master)
        raise
    finally:
        if master is not None:
            os.close(stderr)
    held: List[bytes] = []
    readers = [
        threading.Thread(target=_forward, args=(proc.stdout, "stdout", None), daemon=True),
        threading.Thread(target=_forward_pty, args=(master, lines, held), daemon=True)
        if master is not None
        else threading.Thread(
            target=_forward, args=(proc.stderr, "stderr", lines, held), daemon=True
        ),
    ]
    for t in readers:
        t.start()
    interrupted, pending = _wait(proc)
    for t in readers:
        t.join()
    if held and (proc.returncode == 0 or pending is not None or interrupted):
        # no RwgFailedError carries rwg's message: show it as rwg wrote it
        _write_to("stderr", b"".join(held).decode("utf-8", "replace"))
    if pending is not None:
        raise pending
    if interrupted and proc.returncode == 0:
        # Too late to stop: the study finished, and its result is returned.
        _write_to("stderr", "rwg.run: interrupted after rwg finished the study; its result is kept\n")
    elif interrupted:
        if manifest_text is not None:
            _write_to(
                "stderr",
                "rwg.run: every committed block is kept; to resume, call rwg.run again with the "
                "same manifest and out\n",
            )
        raise KeyboardInterrupt
    if proc.returncode != 0:
        stderr = "\n".join(lines)
        message = _error_message(lines) or f"rwg exited with status {proc.returncode}"
        if proc.returncode < 0:
            message += f"\n(rwg was killed by signal {-proc.returncode})"
        if manifest_text is not None:
            numbered = "\n".join(f"{i:4}  {line}" for i, line in enumerate(manifest_text.splitlines(), 1))
            message += f"\nThe manifest, as written from the dict (line numbers as in the message):\n{numbered}"
        raise RwgFailedError(message, proc.returncode, stderr, cmd, manifest_text)


def _die_with(parent: int) -> Any:
    """The child's set-up on Linux: rwg, in a session of its own (Ctrl-C
    reaches Python, which stops it), gets SIGTERM when this Python dies, even
    by SIGKILL, instead of running on orphaned with the run's lock (its
    committed blocks are kept; the run resumes)."""

    def set_up() -> None:
        import ctypes

        pr_set_pdeathsig = 1
        ctypes.CDLL(None).prctl(pr_set_pdeathsig, int(signal.SIGTERM), 0, 0, 0)
        if os.getppid() != parent:  # it died before the signal was asked for
            os.kill(os.getpid(), signal.SIGTERM)

    return set_up


#: How often the wait for rwg lets Python's signal handlers run (seconds).
_POLL_S = 0.1


def _wait(proc: "subprocess.Popen[bytes]") -> "tuple[bool, Optional[BaseException]]":
    """Waits for rwg to exit; returns whether a ``KeyboardInterrupt`` came
    meanwhile, and the first other exception that did (``SystemExit`` from
    a SIGTERM handler, say), to raise once rwg has exited. Each is passed on
    to rwg as SIGINT, as a shell does: the first stops it after the blocks
    in flight, a second at once; rwg, in a session of its own, is never left
    running behind an exception. The wait is in short steps, so that a
    signal delivered to another thread (``signal.raise_signal`` from a
    timer, as job runners do) is seen within one: Python runs its handlers
    in the main thread only, between steps, never during a blocking
    ``waitpid``."""
    interrupted = False
    pending: Optional[BaseException] = None
    while True:
        try:
            proc.wait(timeout=_POLL_S)
            return interrupted, pending
        except subprocess.TimeoutExpired:
            continue
        except BaseException as e:  # noqa: BLE001 - re-raised once rwg has exited
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
            if isinstance(e, KeyboardInterrupt):
                interrupted = True
            elif pending is None:
                pending = e


def _flush_stderr() -> None:
    try:
        sys.stderr.flush()
    except Exception:  # noqa: BLE001 - no usable stderr: nothing to flush
        pass

"""":
echo "rwg: the interpreter named by RWG_PYTHON or the manifest's python = ... is a shell, not Python 3: name a Python with Gymnasium" >&2
exit 97
"""
# The lines above: a Python string, and for a POSIX shell named as the
# interpreter by mistake a message and an exit, before it could run
# worker.py's text as commands. Below, in what Python 2 parses too: a check
# that this Python can run worker.py, then rwg-worker's loader (given as the
# first argument, taken off the arguments), which makes the modules after it
# importable and runs worker.py.
import sys

if sys.version_info < (3, 6):
    sys.stderr.write(
        "rwg: %s is Python %s; rwg's Gymnasium worker needs Python 3 with Gymnasium: "
        "name another interpreter with RWG_PYTHON or the manifest's python = ...\n"
        % (sys.executable, sys.version.split()[0])
    )
    sys.exit(98)
exec(compile(sys.argv.pop(1), "<rwg loader>", "exec"))

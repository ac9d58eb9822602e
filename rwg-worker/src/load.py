"""rwg's loader of its Python workers, run as `python -c LOAD WORKER [NAME SOURCE]...`
(or by the Gymnasium bridge's boot.py, which takes itself off sys.argv first):
makes each module NAME, of the source SOURCE, importable (run in the order
given), then runs WORKER as the main program. rwg ships these texts inside
its binary; nothing is written to disk.
"""
import sys
import types

_rwg_worker, _rwg_modules = sys.argv[1], sys.argv[2:]
del sys.argv[1:]
for _rwg_name, _rwg_source in zip(_rwg_modules[::2], _rwg_modules[1::2]):
    _rwg_module = types.ModuleType(_rwg_name)
    sys.modules[_rwg_name] = _rwg_module
    exec(compile(_rwg_source, "<%s>" % _rwg_name, "exec"), _rwg_module.__dict__)
del _rwg_modules, _rwg_name, _rwg_source, _rwg_module
exec(compile(_rwg_worker, "<rwg worker>", "exec"))

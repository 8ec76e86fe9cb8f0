"""The child side of ``core/native.py``: run as a script, ``python -I native_worker.py JOB_FOLDER``.

Reads ``request.json`` (module, function, keyword parameters, the parent's ``sys.path``) and ``in.npz`` (array
arguments) from the job folder, calls the function and writes what it returned to ``out.npz`` (``r0``, ``r1``,
... in order). An exception is written to ``error.json`` (one line, and whether it is a refusal) and the exit
code is 3. The module is imported without running its parent packages' ``__init__`` (``techniques/__init__``
registers GPU passes, which need Blender): only pure modules are run here.
"""
import importlib
import json
import os
import sys
import threading
import types
from pathlib import Path


def _bare_parents(module: str, roots: list[str]) -> None:
    """Register the packages above ``module`` as empty packages whose ``__path__`` is their folder."""
    parts = module.split(".")[:-1]
    for depth in range(1, len(parts) + 1):
        name = ".".join(parts[:depth])
        for root in roots:
            folder = Path(root, *parts[:depth])
            if (folder / "__init__.py").exists():
                package = types.ModuleType(name)
                package.__path__ = [str(folder)]
                sys.modules[name] = package
                break
        else:
            return  # not a project package on these roots: import it the usual way


def _exit_with_parent() -> None:
    """End this process when the parent's end of standard input closes (the parent is gone)."""
    def watch() -> None:
        while os.read(0, 1):  # the raw descriptor: a buffered read would hold a lock the shutdown needs
            pass
        os._exit(4)

    threading.Thread(target=watch, daemon=True).start()


def main(job: Path) -> int:
    _exit_with_parent()
    request = json.loads((job / "request.json").read_text())
    sys.path[:] = request["sys_path"]
    import numpy as np

    try:
        _bare_parents(request["module"], request["sys_path"][:1])
        function = getattr(importlib.import_module(request["module"]), request["function"])
        with np.load(job / "in.npz") as given:
            arrays = {name: given[name] for name in given.files}
        result = function(**arrays, **request["params"])
    except Exception as err:  # reported to the parent in one line; the parent raises NativeStepError
        # A ValueError is a refusal in the project's words, passed on as it is; anything else is a failure.
        refusal = isinstance(err, ValueError)
        text = str(err) if refusal else f"failed: {type(err).__name__}: {err}"
        (job / "error.json").write_text(json.dumps({"refusal": refusal, "text": text.replace("\n", " ")}))
        return 3
    values = result if isinstance(result, tuple) else (result,)
    partial = job / "out.partial.npz"
    np.savez(partial, **{f"r{i}": np.asarray(v) for i, v in enumerate(values)})
    partial.replace(job / "out.npz")  # whole or absent: a kill mid-write leaves no half result
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1])))

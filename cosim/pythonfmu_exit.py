"""A guard against a use-after-free at process exit in FMUs built by pythonfmu (0.6.5 to 0.7.0).

Their library keeps a static `std::shared_ptr` to its interpreter state and resets it from a
function marked `__attribute__((destructor))`. When the library is still loaded when the process
exits (fmpy's `freeInstance` does not unload it: the library's own thread holds it; libcosim
keeps it too), the C++ static destructors run first (exit handlers), then the destructor
function resets the already destroyed pointer: it releases the freed control block a second
time. Valgrind shows the invalid read in `finalizePythonInterpreter`; what follows is heap
corruption, and the process aborts at exit now and then (`corrupted double-linked list`,
segmentation faults in the garbage collector), after all its work is done.

The library exports that function (`extern "C" finalizePythonInterpreter`): calling it while the
library's statics are alive resets the pointer in good order (instances still alive keep the
state alive until they are freed), and the call at exit then finds nothing to release. `settle`
does that for every pythonfmu library loaded in this process; the runners call it after a run.
"""

import ctypes
import os


def _loaded_libraries():
    """Paths of the shared libraries mapped into this process."""
    paths = []
    try:
        with open("/proc/self/maps") as maps:
            for line in maps:
                parts = line.split(maxsplit=5)
                if len(parts) == 6 and parts[5].strip().endswith(".so"):
                    paths.append(parts[5].strip())
    except OSError:
        return []
    return list(dict.fromkeys(paths))


def settle():
    """Resets the interpreter state of every loaded pythonfmu library (see the module's
    docstring); returns the paths of the libraries it did that for."""
    settled = []
    for path in _loaded_libraries():
        if "/binaries/" not in path:  # FMU libraries only
            continue
        try:
            # RTLD_NOLOAD: only a library that is loaded already (same handle, no new load).
            lib = ctypes.CDLL(path, mode=os.RTLD_NOLOAD | os.RTLD_LAZY)
        except OSError:
            continue
        hook = getattr(lib, "finalizePythonInterpreter", None)
        if hook is not None:
            hook.restype = None
            hook()
            settled.append(path)
    return settled

"""What exists when a training starts, kept out of Python's garbage collector while it runs.

A whole-heap collection (generation 2) visits every object of the process: about 1.3 million with a simulator and a
runner built, 1.0-1.2 s on a GPU host's core, in whichever iteration triggers it (`agile benchmark` counts them: once
in three of four 20-iteration runs, each three 0.37 s iterations' worth). The env, the runner and the libraries live
as long as the training, so visiting them finds nothing to free; `gc.freeze` moves them out of the collector's view,
and a full collection then visits only what the training itself created.
"""

from __future__ import annotations

import gc
from contextlib import contextmanager


@contextmanager
def heap_frozen():
    """`gc.freeze()` on entry, `gc.unfreeze()` on exit: nothing is lost, the frozen objects go back to the collector
    (cyclic garbage among them is collected after the training, not during it). Freezing is a list splice, not a pass
    over the heap. Where the caller froze the heap already, it is left as it is (nested uses and the caller's own
    freeze keep theirs)."""
    if gc.get_freeze_count() > 0:
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


@contextmanager
def no_collection_while_capturing():
    """Python's garbage collector off while a CUDA graph records. A collection that starts inside a capture can free
    an object whose destructor calls CUDA, a torch `CUDAGraph` of an env built before among them; its `reset` is not
    permitted while a stream captures and fails the capture (seen 2026-12-02 on an H200: `agile eval_all` at its
    seventh task, Warp CUDA error 901). What is garbage already goes at the next collection after the capture. No
    whole-heap collection first: it visits every object of the process (about a million with a simulator built, 0.6-1
    s a capture on a CPU core), for nothing the disabled collector needs. Nested captures (the env step records the
    physics loop) leave it to the outermost."""
    if not gc.isenabled():
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        gc.enable()

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

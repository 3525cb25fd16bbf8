"""The errors agile's library functions raise: one base class, so that a caller (a notebook, a script, the `agile`
commands) catches every input agile refuses with one `except AgileError`.

The message names the field that is wrong and what it may be: the `agile` commands print it as one line and exit 2.
"""

from __future__ import annotations


class AgileError(Exception):
    """Input agile refuses: a task, a file, a count, a config field. The message names the field and the valid
    values."""

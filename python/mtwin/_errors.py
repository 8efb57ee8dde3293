"""Exceptions raised by mtwin."""

from __future__ import annotations

from typing import List, Optional, Tuple


class InputError(ValueError):
    """A problem with an input (machine file, CSV table, part program, dict).

    ``file``, ``line`` and ``column`` locate the first problem (``line`` is 0 and
    ``column`` is ``None`` when it concerns the whole input); ``problems`` lists
    every problem found as ``(file, line, column, message)``. ``str(e)`` is the
    CLI's ``file:line:col: message`` text, one problem per line.
    """

    def __init__(
        self,
        message: str,
        file: str,
        line: int,
        column: Optional[int],
        problems: List[Tuple[str, int, Optional[int], str]],
    ) -> None:
        super().__init__(message)
        self.file = file
        self.line = line
        self.column = column
        self.problems = problems

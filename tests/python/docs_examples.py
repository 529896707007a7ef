"""Running the Python blocks of the Markdown pages as tests (pytest-examples), with an
example's exception reported as an ordinary test failure.

pytest-examples re-raises an example's exception with a traceback of hand-made
frames whose line tables do not match their bytecode on CPython 3.11; pytest's
traceback formatting then fails inside the standard library ("generator raised
StopIteration") and ends the whole session. ``run_example`` turns the exception into
a plain failure that names the page, the line and the error instead.

Its print check replaces ``print`` for the whole process while an example runs and
looks at the whole call stack (``inspect.stack``) on every call, also for prints into
files, which it then drops: Ray disassembles every function it ships
(``dis.dis(..., file=buffer)``, thousands of prints), which made the RLlib example
take minutes instead of seconds, and its function hashes came from empty text.
Prints into a file other than standard output are not an example's documented
output: they go straight to the real ``print``."""

from __future__ import annotations

import builtins
import sys
import traceback
from pathlib import Path
from typing import Any
from unittest import mock

import pytest
from pytest_examples import CodeExample, EvalExample, find_examples, run_code
from pytest_examples.run_code import MockPrintFunction

__all__ = ["examples_of", "run_example"]


def examples_of(*pages: Path) -> list[CodeExample]:
    """The Python blocks of ``pages``, in page order."""
    return list(find_examples(*pages))


def example_lines(error: BaseException, example: CodeExample) -> list[int]:
    """The page's line numbers of the example's own frames in ``error``'s traceback,
    outermost first (pytest-examples' frames carry the page as their file name)."""
    lines = []
    tb = error.__traceback__
    while tb is not None:
        if tb.tb_frame.f_code.co_filename == str(example.path):
            lines.append(tb.tb_lineno)
        tb = tb.tb_next
    return lines


def failure_message(error: BaseException, example: CodeExample) -> str:
    """The error itself, then where in the page the example raised it (with the lines' text)."""
    page_lines = Path(example.path).read_text().splitlines()
    where = []
    for number in example_lines(error, example):
        text = page_lines[number - 1].strip() if 0 < number <= len(page_lines) else ""
        where.append(f"{example.path}:{number}: {text}")
    if not where:
        where.append(f"{example.path}:{example.start_line}: the example starting here")
    error_text = "".join(traceback.format_exception_only(type(error), error)).rstrip()
    return error_text + "\n" + "\n".join(where)


REAL_PRINT = builtins.print
CHECKED_PRINT = MockPrintFunction.__call__


def print_checking_standard_output_only(self: MockPrintFunction, *args: Any, **kwargs: Any) -> None:
    """The print check's ``print``, with prints into other files passed to the real one."""
    if kwargs.get("file") not in (None, sys.stdout):
        REAL_PRINT(*args, **kwargs)
    else:
        CHECKED_PRINT(self, *args, **kwargs)


def run_example(example: CodeExample, eval_example: EvalExample) -> None:
    """Runs ``example`` and checks the ``#>`` outputs of its prints; an exception the
    example raises is reported as this test's failure, without its traceback."""
    try:
        # One frame more between the example's print and the check: the wrapper's.
        with mock.patch.object(MockPrintFunction, "__call__", print_checking_standard_output_only), \
                mock.patch.object(run_code, "parent_frame_id", run_code.parent_frame_id + 1):
            eval_example.run_print_check(example)
    except pytest.fail.Exception:
        raise  # an output mismatch, already an ordinary failure
    except Exception as error:  # noqa: BLE001 - any error of the example fails its test
        message = failure_message(error, example)
    else:
        return
    pytest.fail(message, pytrace=False)

"""Guards that turn a hang into a test failure (speed itself is measured in benchmarks)."""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from typing import Iterator


@contextmanager
def alarm(seconds: int = 30, what: str = "the call") -> Iterator[None]:
    """Fail if the block runs longer than ``seconds``: a hang guard, far above the
    expected time, never a speed check.  A no-op where SIGALRM is missing or off the
    main thread.

    >>> with alarm(5):
    ...     pass
    """
    if not hasattr(signal, "SIGALRM") or threading.current_thread() is not threading.main_thread():
        yield
        return

    def timeout(signum, frame):
        raise AssertionError(f"{what} ran for more than {seconds} s: a hang")

    old = signal.signal(signal.SIGALRM, timeout)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)

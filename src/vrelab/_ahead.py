"""Work one item ahead in a background thread: the one read-ahead of the package."""

from __future__ import annotations

from typing import Any, Iterator, TypeVar

T = TypeVar("T")


class Ahead(Iterator[Any]):
    """Iterate ``items`` in a background thread, at most ``depth`` items ahead of the consumer.

    Memory: up to ``depth + 1`` items more (the queue and the one waiting to enter it). An
    exception in the producer is raised in the consumer;
    :meth:`close` (also called when the consumer is garbage-collected) stops the producer and
    waits for it, so no thread outlives the pass. The simulation synthesises its drive one block
    ahead with it, the analysis reads the next block of a file (:func:`prefetch`): numpy FFTs,
    sosfilt, h5py reads and memmap page faults release the GIL, so the two overlap on two cores.
    """

    _DONE = object()

    def __init__(self, items: Iterator[Any], depth: int = 1, name: str = "vrelab-ahead") -> None:
        import queue
        import threading

        self._closed = True  # until the thread runs: close() and __del__ then have nothing to do
        self._q: Any = queue.Queue(maxsize=max(1, int(depth)))
        self._stop = threading.Event()

        def work() -> None:
            try:
                for item in items:
                    if not self._put(item):
                        return
                self._put(self._DONE)
            except BaseException as exc:  # re-raised in the consumer
                self._put(exc)

        self._thread = threading.Thread(target=work, name=name, daemon=True)
        self._thread.start()
        self._closed = False

    def _put(self, item: object) -> bool:
        import queue

        while not self._stop.is_set():
            try:
                self._q.put(item, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False

    def __next__(self) -> Any:
        if self._closed:
            raise StopIteration
        item = self._q.get()
        if item is self._DONE:
            self.close()
            raise StopIteration
        if isinstance(item, BaseException):
            self.close()
            raise item
        return item

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        self._thread.join()

    def __del__(self) -> None:
        self.close()


def prefetch(items: Iterator[T], depth: int = 1, name: str = "vrelab-read") -> Iterator[T]:
    """Yield ``items``, producing the next ``depth`` in a background thread (:class:`Ahead`);
    the thread is stopped and joined however the consumer leaves (end, break or error)."""
    ahead = Ahead(items, depth, name)
    try:
        yield from ahead
    finally:
        ahead.close()

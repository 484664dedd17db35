"""Where the service runs its searches: the first in flight on the primary thread, any started
meanwhile on a thread of its own that ends with it."""

from __future__ import annotations

import asyncio
import threading

import numba

from photomodel.service._threads import SearchThreads


def _where(gate: threading.Event | None = None) -> tuple[str, int]:
    if gate is not None:
        gate.wait(10)
    return threading.current_thread().name, numba.get_num_threads()


def test_one_at_a_time_always_the_primary_thread() -> None:
    async def main() -> list[tuple[str, int]]:
        threads = SearchThreads()
        try:
            return [await threads.run(_where) for _ in range(3)]
        finally:
            threads.close()

    seen = asyncio.run(main())
    assert {name for name, _ in seen} == {seen[0][0]}
    assert seen[0][0].startswith("photomodel-search_")
    assert seen[0][1] == numba.config.NUMBA_NUM_THREADS


def test_a_second_search_runs_beside_it_on_a_thread_that_ends() -> None:
    async def main() -> list[tuple[str, int]]:
        threads = SearchThreads()
        gate = threading.Event()
        try:
            first = asyncio.ensure_future(threads.run(lambda: _where(gate)))
            await asyncio.sleep(0.05)
            second = await threads.run(_where)   # runs while the first waits on the gate
            gate.set()
            return [await first, second]
        finally:
            threads.close()

    before = threading.active_count()
    (name1, n1), (name2, n2) = asyncio.run(main())
    assert name1.startswith("photomodel-search_") and name2.startswith("photomodel-search-extra")
    assert n1 == n2 == numba.config.NUMBA_NUM_THREADS
    for _ in range(100):  # the extra thread (and the closed primary) end
        if threading.active_count() <= before:
            break
        threading.Event().wait(0.05)
    assert threading.active_count() <= before


def test_a_cancelled_request_frees_the_primary_thread_when_its_call_ends() -> None:
    async def main() -> tuple[str, str]:
        threads = SearchThreads()
        gate = threading.Event()
        try:
            task = asyncio.ensure_future(threads.run(lambda: _where(gate)))
            await asyncio.sleep(0.05)
            task.cancel()
            await asyncio.sleep(0.05)
            gate.set()
            for _ in range(200):  # the call ends and frees the primary thread
                if not threads._primary_busy:
                    break
                await asyncio.sleep(0.025)
            name = (await threads.run(_where))[0]
            return name, "cancelled" if task.cancelled() else "ran"
        finally:
            threads.close()

    name, state = asyncio.run(main())
    assert state == "cancelled" and name.startswith("photomodel-search_")


def test_a_thread_that_is_no_event_loop_runs_its_calls_on_the_same_primary_thread() -> None:
    """The OPC UA face's worker calls in: its searches share the HTTP side's OpenMP team."""
    threads = SearchThreads()
    try:
        async def on_loop() -> str:
            return (await threads.run(_where))[0]

        from_loop = asyncio.run(on_loop())
        seen: list[str] = []
        worker = threading.Thread(target=lambda: seen.append(threads.call(_where)[0]))
        worker.start()
        worker.join(10)
        assert seen == [from_loop] and from_loop.startswith("photomodel-search_")
    finally:
        threads.close()
    assert threads.call(_where)[0].startswith("photomodel-search_")   # made again after close
    threads.close()

"""``PreparedModels`` (issue 50): models prepared on first use, the least recently used dropped
beyond the capacity, ``peek`` and ``drop``, and one preparation when threads ask at once."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import pytest
from identify_helpers import IdentifyData

from photomodel.identify import PreparedModels
from photomodel.locate import Locator
from photomodel.model import PhotoModel


def _counting_load(data: IdentifyData, delay_s: float = 0.0
                   ) -> tuple[Callable[[str], PhotoModel], list[str]]:
    """A ``load`` of the test models by name that records each call."""
    models = {m.name: m for m in data.models}
    calls: list[str] = []

    def load(name: str) -> PhotoModel:
        calls.append(name)
        time.sleep(delay_s)
        return models[name]          # KeyError for a name it does not hold

    return load, calls


def _counts(cache: PreparedModels) -> tuple[int, int, int, int, int]:
    s = cache.stats()
    return s.prepared, s.capacity, s.hits, s.misses, s.evicted


def test_least_recently_used_is_dropped(identify_data: IdentifyData) -> None:
    load, calls = _counting_load(identify_data)
    cache = PreparedModels(load, identify_data.rig, capacity=2)
    a = cache.get("No.3")
    assert isinstance(a, Locator) and a.model.name == "No.3" and a.rig is identify_data.rig
    cache.get("No.5")
    assert cache.get("No.3") is a                 # a hit: now the most recently used
    assert _counts(cache) == (2, 2, 1, 2, 0)
    cache.get("No.9")                             # No.5 is the least recently used
    assert "No.5" not in cache and "No.3" in cache and "No.9" in cache and len(cache) == 2
    assert _counts(cache) == (2, 2, 1, 3, 1)
    cache.get("No.5")                             # prepared again, No.3 goes
    assert "No.3" not in cache and calls == ["No.3", "No.5", "No.9", "No.5"]
    assert _counts(cache) == (2, 2, 1, 4, 2)


def test_peek_neither_loads_nor_reorders_and_drop_forgets(identify_data: IdentifyData
                                                          ) -> None:
    load, calls = _counting_load(identify_data)
    cache = PreparedModels(load, identify_data.rig, capacity=2)
    assert cache.peek("No.3") is None and calls == []
    first = cache.get("No.3")
    cache.get("No.5")
    assert cache.peek("No.3") is first            # still the least recently used ...
    cache.get("No.9")
    assert cache.peek("No.3") is None and cache.peek("No.5") is not None   # ... so it went
    assert cache.stats().hits == 0                # peeks are no hits
    cache.drop("No.5")
    cache.drop("No.5")                            # forgetting twice, or what is not held,
    cache.drop("No.99")                           # is no error
    assert "No.5" not in cache and len(cache) == 1
    assert cache.get("No.5") is not None and calls == ["No.3", "No.5", "No.9", "No.5"]


def test_put_holds_a_locator_under_its_models_name(identify_data: IdentifyData) -> None:
    load, calls = _counting_load(identify_data)
    cache = PreparedModels(load, identify_data.rig, capacity=1)
    mine = cache.make(identify_data.models[1])
    assert "No.5" not in cache                    # make() does not hold it
    cache.put(mine)
    assert cache.get("No.5") is mine and calls == []
    cache.put(cache.make(identify_data.models[0]))
    assert "No.5" not in cache and cache.stats().evicted == 1


@pytest.mark.parametrize("capacity", [0, -3])
def test_capacity_below_one_is_refused(identify_data: IdentifyData, capacity: int) -> None:
    load, _ = _counting_load(identify_data)
    with pytest.raises(ValueError, match="capacity"):
        PreparedModels(load, identify_data.rig, capacity=capacity)


def test_a_failed_load_is_not_held_and_is_tried_again(identify_data: IdentifyData) -> None:
    load, calls = _counting_load(identify_data)
    cache = PreparedModels(load, identify_data.rig, capacity=2)
    for _ in range(2):
        with pytest.raises(KeyError):
            cache.get("No.99")
    assert calls == ["No.99", "No.99"] and len(cache) == 0


def test_threads_asking_for_one_model_prepare_it_once(identify_data: IdentifyData) -> None:
    load, calls = _counting_load(identify_data, delay_s=0.3)   # all four wait on the first
    prepared: list[Locator] = []
    cache = PreparedModels(load, identify_data.rig, capacity=2, prepare=prepared.append)
    start = threading.Barrier(4)
    got: list[Locator] = []
    errors: list[BaseException] = []

    def ask() -> None:
        start.wait()
        try:
            got.append(cache.get("No.5"))
        except BaseException as exc:  # noqa: BLE001 - reported by the assertion below
            errors.append(exc)

    threads = [threading.Thread(target=ask) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=60)
    assert errors == [] and len(got) == 4
    assert calls == ["No.5"] and len(prepared) == 1
    assert all(g is got[0] for g in got) and prepared[0] is got[0]
    assert _counts(cache) == (1, 2, 3, 1, 0)


def test_a_model_dropped_while_it_is_prepared_is_not_kept(identify_data: IdentifyData) -> None:
    """A removal from the library (``drop``) that meets a preparation of the old file wins:
    the caller gets its Locator, the cache does not keep it."""
    models = {m.name: m for m in identify_data.models}
    loading, release = threading.Event(), threading.Event()

    def load(name: str) -> PhotoModel:
        loading.set()
        assert release.wait(timeout=60)
        return models[name]

    cache = PreparedModels(load, identify_data.rig, capacity=2)
    got: list[Locator] = []
    asker = threading.Thread(target=lambda: got.append(cache.get("No.5")))
    asker.start()
    assert loading.wait(timeout=60)
    cache.drop("No.5")
    release.set()
    asker.join(timeout=60)
    assert len(got) == 1 and got[0].model.name == "No.5"
    assert "No.5" not in cache and len(cache) == 0

"""The cache policy (birdocp.engine.cache): what is built from an object is kept by that object,
cleared by clear_caches, counted by cache_sizes; a process reuses its graphs across studies."""
from __future__ import annotations

import gc

from birdocp.engine.cache import cache_sizes, clear_caches, owned_cache


class _Owner:
    pass


def test_owned_cache_lives_with_its_owner_and_is_cleared_by_clear_caches():
    a, b = _Owner(), _Owner()
    built = []

    def make(tag):
        built.append(tag)
        return [tag]

    first = owned_cache(a).build("f", lambda: make("a"))
    assert owned_cache(a).build("f", lambda: make("again")) is first  # built once, kept by a
    assert owned_cache(b).build("f", lambda: make("b")) is not first  # b keeps its own
    assert built == ["a", "b"]
    assert cache_sizes()["owned: _Owner.graphs"] == 2
    small = owned_cache(a, "big", maxsize=1)
    small.put(1, "x")
    small.put(2, "y")  # the least recently used entry goes
    assert small.get(1) is None and small.get(2) == "y"
    clear_caches()
    assert len(owned_cache(a)) == 0 and len(small) == 0
    owned_cache(a).build("f", lambda: make("a2"))
    assert built[-1] == "a2"  # rebuilt after clear_caches
    del a, b, first, small
    gc.collect()
    assert "owned: _Owner.graphs" not in cache_sizes()  # gone with its owners


def test_a_process_builds_the_model_and_its_shooting_graphs_once(monkeypatch):
    """trim, trim, level, level in one process: at most one model build (none when an earlier test
    built it) and one set of shooting graphs per problem, reused by the second solve."""
    import birdocp
    from birdocp.bird import model as bird_model
    from birdocp.engine import shooting_graphs

    counts = {"model": 0, "graphs": 0}
    for cls, key in ((bird_model.BirdModel, "model"), (shooting_graphs.ShootingGraphs, "graphs")):
        def counted(self, *a, _init=cls.__init__, _key=key, **k):
            counts[_key] += 1
            _init(self, *a, **k)
        monkeypatch.setattr(cls, "__init__", counted)
    cfg = birdocp.Config()
    first = birdocp.trim(cfg)
    after_trim = dict(counts)
    assert after_trim["model"] <= 1 and after_trim["graphs"] <= 1
    again = birdocp.trim(cfg)
    assert counts == after_trim  # nothing rebuilt
    assert again.cycle.multipliers.tolist() == first.cycle.multipliers.tolist()
    birdocp.level(cfg)
    after_level = dict(counts)
    assert after_level["model"] == after_trim["model"]  # the level solve reuses the model
    birdocp.level(cfg)
    assert counts == after_level


def test_a_pickled_owner_arrives_with_empty_caches():
    """An owner sent to a worker process is pickled without its graphs (they are rebuilt there)."""
    import pickle

    a = _Owner()
    owned_cache(a).put("graph", list(range(1000)))
    b = pickle.loads(pickle.dumps(a))
    assert len(owned_cache(a)) == 1 and len(owned_cache(b)) == 0
    assert len(pickle.dumps(a)) < 400  # the entry was not pickled

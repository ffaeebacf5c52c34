"""poir_mjx.cached.builder: one entry per call's meaning, however the call is spelled."""

from poir_mjx.cached import builder


def test_every_spelling_of_one_call_shares_one_build():
    built = []

    @builder
    def make(task, steps, observation="low_dim", physics="reference"):
        built.append((task, steps, observation, physics))
        return object()

    first = make("lift", 4)
    assert make("lift", 4, "low_dim") is first  # a default written out (functools.lru_cache: a second build)
    assert make("lift", steps=4, physics="reference") is first  # by keyword
    assert make(task="lift", observation="low_dim", steps=4) is first
    assert make("lift", 4, "object") is not first
    assert built == [("lift", 4, "low_dim", "reference"), ("lift", 4, "object", "reference")]
    assert make.cache_info().currsize == 2 and make.__name__ == "make"
    make.cache_clear()
    assert make("lift", 4) is not first and make.cache_info().currsize == 1


def test_a_bounded_builder_keeps_its_most_recent_entries():
    @builder(maxsize=1)
    def square(x):
        return [x * x]

    a = square(2)
    assert square(x=2) is a
    square(3)
    assert square(2) is not a and square.cache_info().maxsize == 1

"""mdl.records: a record behaves as the frozen dataclass of the same fields does (construction, defaults,
keywords, repr, equality, hash, frozen fields, match, copy and pickle), and refuses what it does not do."""

from __future__ import annotations

import copy
import dataclasses
import pickle
from typing import Any, ClassVar

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mdl.records import record, replace


@record
class Three:
    """A record of three fields, the last with a default."""

    a: int
    b: Any
    c: float = 1.0


@dataclasses.dataclass(frozen=True)
class ThreeDC:
    a: int
    b: Any
    c: float = 1.0


@record
class One:
    x: Any


@dataclasses.dataclass(frozen=True)
class OneDC:
    x: Any


@record
class Empty:
    pass


@record
class Other:
    x: Any


values = st.one_of(
    st.integers(),
    st.floats(allow_nan=False),
    st.text(max_size=5),
    st.none(),
    st.booleans(),
    st.tuples(st.integers(), st.floats(allow_nan=False)),
)


def _as_dc(made: Any) -> Any:
    return {Three: ThreeDC, One: OneDC}[type(made)](*made._values(made)[: len(made.__record_fields__)])


@given(values, values, values, values)
def test_a_record_is_shown_compared_and_hashed_as_its_dataclass(a, b, c, d):
    for x, y, made in ((Three(a, b, c), Three(a, d, c), ThreeDC(a, b, c)), (One(a), One(b), OneDC(a))):
        assert repr(x) == repr(made).replace("DC(", "(", 1)
        assert (x == y) == (_as_dc(x) == _as_dc(y))
        assert x == copy.copy(x) == pickle.loads(pickle.dumps(x)) == copy.deepcopy(x)
        if x == y:
            assert hash(x) == hash(y)


def test_defaults_keywords_and_match():
    assert Three(1, 2) == Three(a=1, b=2, c=1.0) == Three(1, b=2)
    assert Three(1, 2) != Three(1, 2, 3.5)
    assert Three.__match_args__ == Three.__record_fields__ == ("a", "b", "c")
    assert Three.__doc__ == "A record of three fields, the last with a default."
    match Three(1, "x"):
        case Three(a, b, c=c):
            assert (a, b, c) == (1, "x", 1.0)
        case _:
            pytest.fail("no match")
    with pytest.raises(TypeError):
        Three(1)
    with pytest.raises(TypeError):
        Three(1, 2, 3, 4)


def test_records_of_other_classes_or_no_fields():
    assert One(1) != Other(1)
    assert One(1) != (1,)
    assert Empty() == Empty()
    assert hash(Empty()) == hash(Empty()) == hash(())  # as the dataclass's: the same in every process
    assert repr(Empty()) == "Empty()"
    assert repr(One((1, 2))) == "One(x=(1, 2))"
    assert len({One(1), One(1), One(2)}) == 2


def test_a_field_cannot_be_assigned_or_deleted():
    made = Three(1, 2)
    with pytest.raises(dataclasses.FrozenInstanceError, match="cannot assign to field 'a'"):
        made.a = 5  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError, match="cannot delete field 'b'"):
        del made.b  # type: ignore[misc]
    assert made == Three(1, 2)


def test_a_record_refuses_what_it_does_not_do():
    with pytest.raises(TypeError, match="immutable"):

        @record
        class Listed:
            x: list[int] = []  # noqa: RUF012

    with pytest.raises(TypeError, match="immutable"):

        @record
        class Fielded:
            x: int = dataclasses.field(default=1)

    with pytest.raises(TypeError, match="follows one with a default"):

        @record
        class Order:
            x: int = 1
            y: int  # type: ignore[misc]

    with pytest.raises(TypeError, match="ClassVar"):

        @record
        class Classy:
            x: ClassVar[int] = 1

    with pytest.raises(TypeError, match="inherits"):

        @record
        class Child(One):
            y: int

    with pytest.raises(TypeError, match="are its own"):

        @record
        class Compared:
            x: int

            def __eq__(self, other: object) -> bool:
                return True

    with pytest.raises(TypeError, match="own attribute"):

        @record
        class Shadowing:
            _values: int

    with pytest.raises(TypeError, match="__post_init__"):

        @record
        class Checked:
            x: int

            def __post_init__(self) -> None:
                pass


def test_a_record_is_no_dataclass():
    """dataclasses.fields/replace refuse a record, loudly (the library's public types stay dataclasses)."""
    assert not dataclasses.is_dataclass(One(1))
    with pytest.raises(TypeError):
        dataclasses.replace(One(1), x=2)  # type: ignore[type-var]


def test_replace_makes_a_new_record_of_the_changed_fields():
    made = Three(1, "x")
    again = replace(made, c=2.5)
    assert again == Three(1, "x", 2.5) and made == Three(1, "x")
    assert replace(Empty()) == Empty()
    with pytest.raises(TypeError):
        replace(made, d=1)


class Named(One):
    """A plain subclass of a record (as mdl.device.connection.Connection of Endpoint): its fields, its methods."""

    def twice(self) -> Any:
        return self.x * 2


def test_a_plain_subclass_keeps_the_fields_and_tells_its_class():
    made = Named(3)
    assert made.twice() == 6 and repr(made) == "Named(x=3)"
    assert made == Named(3) and made != One(3)
    assert replace(made, x=4) == Named(4)

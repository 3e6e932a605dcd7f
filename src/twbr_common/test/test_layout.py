import numpy as np
import pytest

from twbr_common.layout import Layout


def test_slots_and_blocks_are_indexed_in_order():
    lay = Layout(("a", ("gains", 3), "b"))
    assert (lay["a"], lay["gains"], lay["b"], len(lay)) == (0, 1, 4, 5)
    assert lay.block("gains") == slice(1, 4)


def test_a_name_not_in_the_layout_fails_loudly():
    lay = Layout(("rate", "gain"))
    with pytest.raises(KeyError, match="no slot 'rates'"):
        lay["rates"]


def test_a_name_declared_twice_is_refused():
    with pytest.raises(ValueError, match="twice"):
        Layout(("a", "b", "a"))


def test_pack_and_unpack_by_name():
    lay = Layout(("x", ("block", 2), "y"))
    v = lay.pack({"y": 2.0, "x": 1.0, "unused": 9.0})
    assert v.tolist() == [1.0, 0.0, 0.0, 2.0]
    assert lay.unpack(np.array([5.0, 0.0, 0.0, 6.0])) == {"x": 5.0, "y": 6.0}

"""Every node type declares each of its parameters once, and everything reads that declaration."""

from __future__ import annotations

import py_trees
import pytest

from tactile_bt.errors import ParameterValueError
from tactile_bt.tree.behaviours import DECORATORS, LEAVES, CableEnd, ForceHold, Retry, TactileServo
from tactile_bt.tree.declaration import Parameter, Parameterised, undeclared_arguments
from tactile_bt.tree.parameters import check_bound, parameters_of
from tactile_bt.tree.reference import reference_markdown


def every_node_class():
    return sorted({**LEAVES, **DECORATORS}.items())


@pytest.fixture(scope="module")
def reference() -> str:
    return reference_markdown()


@pytest.mark.parametrize("type_name,cls", every_node_class())
def test_every_parameter_is_declared_once_with_doc_unit_bound_and_reference_row(type_name, cls, reference):
    assert issubclass(cls, Parameterised)
    table = reference.split(f"#### `{type_name}`\n", 1)[1].split("\n#### ", 1)[0]
    for p in parameters_of(cls):
        where = f"{type_name}.{p.name}"
        # one declaration: the class attribute of the most derived class that declares it
        owner = next(k for k in cls.__mro__ if isinstance(vars(k).get(p.name), Parameter) or k is Parameterised)
        assert p.name == "name" or vars(owner)[p.name] is p, where
        assert p.doc.strip(), f"{where} has no doc"
        if p.type_name in ("float", "int", "list[float]"):
            assert p.name == "name" or p.unit_declared, f"{where}: declare its unit (unit=None for a plain number)"
        if p.type_name in ("float", "list[float]"):
            assert p.bound is not None, f"{where} has no bound"
        if p.bound is not None and not p.required:
            check_bound(p.name, p.default, p.bound)  # raises when a default is out of range
        assert f"| `{p.name}` |" in table, f"{where} missing from the reference"
    # no second place that declares parameters, bounds or units
    assert undeclared_arguments(cls) == []
    for klass in cls.__mro__:
        for legacy in ("parameter_bounds", "parameter_units", "set_parameter"):
            assert legacy not in vars(klass) or klass is Parameterised, f"{klass.__name__}.{legacy}"


@pytest.mark.parametrize("type_name,cls", every_node_class())
def test_every_node_builds_with_its_defaults_and_keeps_them(type_name, cls):
    node = cls(py_trees.behaviours.Dummy()) if type_name in DECORATORS else cls()
    values = node.parameter_values()
    assert list(values) == [p.name for p in parameters_of(cls)]
    assert node.name == cls.parameters["name"].default


def test_python_construction_and_set_parameter_judge_like_yaml():
    with pytest.raises(ParameterValueError, match=r"cable_end 'end': reach_m must not be negative \(got -1.0 m\)"):
        CableEnd(name="end", reach_m=-1)
    leaf = CableEnd(reach_m="3 px")  # a unit in Python too: three tactels of the default pad
    assert leaf.reach_m == pytest.approx(0.015)
    with pytest.raises(ParameterValueError, match="reach_m must not be negative"):
        leaf.set_parameter("reach_m", -0.001)
    assert leaf.reach_m == pytest.approx(0.015)
    with pytest.raises(TypeError, match="unexpected keyword argument 'reach'"):
        CableEnd(reach=0.01)
    with pytest.raises(ValueError, match="fixed"):
        leaf.set_parameter("on_line_key", "/x")
    retry = Retry(ForceHold(), num_failures=2)
    retry.set_parameter("num_failures", 5)
    assert retry.num_failures == 5
    with pytest.raises(ParameterValueError, match="num_failures must be >= 1"):
        retry.set_parameter("num_failures", 0)


def test_the_hook_rebuilds_derived_state_and_a_refused_value_is_undone():
    leaf = ForceHold(kp=1e-6, output_limit=0.01)
    leaf.set_parameter("output_limit", 0.002)
    assert leaf.pid.output_limit == [0.002] and leaf.pid.kp == [1e-6]
    servo = TactileServo()
    before = list(servo.band)
    with pytest.raises(ValueError, match="band"):
        servo.set_parameter("band", (1.0, 2.0))  # four components
    assert list(servo.band) == before


def test_a_leaf_of_ones_own_declares_its_parameters_in_one_place():
    from tactile_bt.tree import NON_NEGATIVE, TactileBehaviour

    class Wait(TactileBehaviour):
        """Succeed after ``hold_s``."""

        hold_s = Parameter(0.1, bound=NON_NEGATIVE, doc="How long to wait (s).")
        label = Parameter("x", doc="A label.")

        def parameters_changed(self, changed):
            self.twice_s = 2 * self.hold_s

        def update(self):
            return py_trees.common.Status.SUCCESS

    w = Wait(hold_s="50 ms")
    assert (w.name, w.hold_s, w.twice_s, w.label) == ("wait", 0.05, 0.1, "x")
    assert {p.name: p.unit for p in parameters_of(Wait)} == {"name": None, "hold_s": "s", "label": None}
    with pytest.raises(ParameterValueError, match="Wait 'w': hold_s must not be negative"):
        Wait("w", hold_s=-1.0)


def test_a_second_declaration_is_refused():
    from tactile_bt.errors import PluginError
    from tactile_bt.tree import POSITIVE, TactileBehaviour
    from tactile_bt.tree.registry import register_node

    with pytest.raises(TypeError, match="parameter_bounds: declare each parameter once"):
        class Bounded(TactileBehaviour):
            parameter_bounds = {"x_m": POSITIVE}

    class Signed(TactileBehaviour):
        def __init__(self, name: str = "signed", x_m: float = 1.0) -> None:
            super().__init__(name)

    with pytest.raises(PluginError, match=r"Signed.__init__\(x_m\) takes a value no Parameter declares"):
        register_node("signed", Signed)


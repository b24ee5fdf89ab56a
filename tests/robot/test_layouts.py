"""The packed work arrays of the compiled kernels: every layout's fields are disjoint and cover
its array, the kernels' offsets are the layouts', and packing and viewing round-trip."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_bt.robot import kernels as rk
from tactile_bt.robot.layout import Layout
from tactile_bt.robot.kinematics import LWR4Kinematics
from tactile_bt.robot.redundancy import LimitAvoidance
from tactile_bt.robot.stepping import ArmStepper
from tactile_bt.sim import kernels as sk

LAYOUTS = {"KIN": rk.KIN, "ARM": rk.ARM, "IO": rk.IO, "OUT": rk.OUT, "WORK": rk.WORK, "CONTACT": rk.CONTACT,
           "OBJ": sk.OBJ, "PAD": sk.PAD, "BROAD": sk.BROAD, "LAST": sk.LAST, "JOB": sk.JOB}


@pytest.mark.parametrize("name", sorted(LAYOUTS))
def test_every_number_of_an_array_belongs_to_exactly_one_field(name):
    lay = LAYOUTS[name]
    owner = np.full(lay.size, -1)
    for k, field in enumerate(lay.fields):
        part = owner[lay.offset(field):lay.end(field)]
        assert np.all(part == -1), f"{name}.{field} overlaps another field"
        part[:] = k
    assert np.all(owner >= 0), f"{name} has numbers no field owns"


@pytest.mark.parametrize("name", sorted(LAYOUTS))
def test_pack_and_view_round_trip(name):
    lay = LAYOUTS[name]
    rng = np.random.default_rng(7)
    values = {f: rng.standard_normal(lay.shape(f)) for f in lay.fields}
    packed = lay.pack(**values)
    assert packed.shape == (lay.size,)
    for field, value in values.items():
        view = lay.view(packed, field)
        assert np.array_equal(view.reshape(value.shape), value)
        assert np.shares_memory(view, packed)
    assert set(lay.unpack(packed)) == set(lay.fields)


def test_the_kernels_module_constants_are_the_layouts_offsets():
    assert (rk.KIN_SIZE, rk.ARM_SIZE, rk.IO_SIZE, rk.OUT_SIZE, rk.WORK_SIZE) == (
        rk.KIN.size, rk.ARM.size, rk.IO.size, rk.OUT.size, rk.WORK.size)
    assert (sk.OBJ_SIZE, sk.PAD_SIZE, sk.BROAD_SIZE, sk.LAST_SIZE) == (sk.OBJ.size, sk.PAD.size, sk.BROAD.size,
                                                                       sk.LAST.size)
    assert rk.W_TT == rk.WORK.offset("T_t") and rk.O_RRES == rk.OUT.offset("rate_residual")
    assert sk.F_P == sk.OBJ.offset("params") and sk.LAST_DEEPEST == sk.LAST.offset("deepest")
    for offset in (rk.K_QDMAX, rk.A_W, rk.I_RADIUS, rk.O_SAT, rk.W_SC, sk.F_BHI, sk.PF_ADC, sk.LAST_K):
        assert type(offset) is int  # a plain int: numba folds it into the machine code
    # the contact record a contact kernel writes is w_t then K_xt in the arm's work array
    assert rk.WORK.offset("Kx_t") == rk.WORK.end("w_t")
    assert rk.WORK.end("Kx_t") - rk.WORK.offset("w_t") == rk.CONTACT.size


def test_a_layout_refuses_a_field_declared_twice_or_the_wrong_array():
    with pytest.raises(ValueError, match="twice"):
        Layout("x", ("a", 1), ("a", 2))
    lay = Layout("x", ("a", 2), ("b", (2, 2)))
    with pytest.raises(ValueError, match="6 numbers"):
        lay.view(np.zeros(5), "a")
    with pytest.raises(ValueError, match="takes 4 numbers"):
        lay.pack(b=np.ones(3))
    with pytest.raises(KeyError, match="fields: a, b"):
        lay.offset("c")


def test_the_packed_arm_and_model_read_back_as_given():
    kin = LWR4Kinematics()
    packed = kin.packed
    assert np.array_equal(rk.KIN.view(packed, "q_max"), kin.q_max)
    assert np.array_equal(rk.KIN.view(packed, "mount"), kin.mount)
    avoid = LimitAvoidance()
    arm = rk.pack_arm(np.full(7, 200.0), np.full(7, 0.2), avoid)
    assert np.all(rk.ARM.view(arm, "stiffness") == 200.0) and rk.ARM.view(arm, "avoid_on")[0] == 1.0
    assert rk.ARM.view(rk.pack_arm(np.ones(7), np.ones(7), None), "avoid_on")[0] == 0.0
    with pytest.raises(ValueError, match="7 DH rows"):
        rk.pack_kinematics(np.zeros(6), kin.a, kin.alpha, np.eye(4), kin.mount, kin.q_min, kin.q_max, kin.qd_max)


def test_the_stepper_loads_the_state_where_the_kernels_read_it():
    stepper = ArmStepper()
    q_eq, q, twist = np.arange(7.0), -np.arange(7.0), np.linspace(0, 1, 6)
    stepper.load(q_eq, q, 0.004, 2.0, twist, ik_damping=0.05, sigma_threshold=0.06, max_step=1e-3, tol=1e-4,
                 max_iter=60, pad_radius=0.05)
    io = stepper.io
    assert np.array_equal(io[rk.I_QEQ:rk.I_QEQ + 7], q_eq) and np.array_equal(io[rk.I_Q:rk.I_Q + 7], q)
    assert np.array_equal(io[rk.I_TWIST:rk.I_TWIST + 6], twist)
    assert (io[rk.I_DT], io[rk.I_MODE], io[rk.I_EPS], io[rk.I_ITER], io[rk.I_RADIUS]) == (0.004, 2.0, 0.06, 60, 0.05)


def test_a_copied_stepper_writes_into_its_own_arrays():
    import copy

    stepper = ArmStepper()
    twin = copy.deepcopy(stepper)
    twin.load(np.ones(7), np.ones(7), 0.004, 1.0, np.ones(7), ik_damping=0.05, sigma_threshold=0.05, max_step=1e-3,
              tol=1e-4, max_iter=60, pad_radius=0.05)
    assert np.all(twin.io[rk.I_QEQ:rk.I_QEQ + 7] == 1.0) and np.all(stepper.io == 0.0)

"""The plugin contract declares Params once: the generic argument (``State[SpeedParams]``) is the type's Params, and
a ``Params`` that disagrees with it is refused when the class is registered, naming the class."""

from __future__ import annotations

from typing import Any, TypeVar

import pytest

import fsm
from fsm.loading.registry import using


class SpeedParams(fsm.StateParams):
    speed: float = 1.0


class OtherParams(fsm.StateParams):
    gain: float = 2.0


class FasterParams(SpeedParams):
    boost: float = 0.5


class Drive(fsm.State[SpeedParams]):
    def tick(self, ctx: fsm.Context) -> None:
        ctx.vars["speed"] = self.params.speed


def test_the_generic_argument_is_the_params() -> None:
    assert Drive.Params is SpeedParams and Drive.params_argument is SpeedParams
    registry = fsm.Registry()
    registry.add_state(Drive)
    registry.add_transition(fsm.Registry.with_builtins().transitions["Timeout"])
    registry.add_state(fsm.Registry.with_builtins().states["Final"])
    machine = fsm.load({"initial": "d", "states": [{"id": "d", "type": "Drive", "speed": 0.4},
                                                   {"id": "end", "type": "Final"}],
                        "transitions": [{"type": "Timeout", "from": "d", "to": "end", "seconds": 0.1}]},
                       registry=registry)
    assert fsm.run(machine).outcome == "succeeded" and machine.ctx.vars["speed"] == 0.4


def test_a_params_that_disagrees_is_refused_at_registration_naming_the_class() -> None:
    class Confused(fsm.State[SpeedParams]):
        Params = OtherParams

    with pytest.raises(fsm.RegistrationError, match=r"test_plugin_contract\..*Confused.*'Confused'.*OtherParams "
                                                    r"disagrees with its generic argument SpeedParams"):
        fsm.Registry().add_state(Confused)
    with using(fsm.Registry()), pytest.raises(fsm.RegistrationError, match="Confused"):
        fsm.register_state(Confused)


def test_a_params_that_narrows_the_argument_and_subclasses_agree() -> None:
    class Faster(fsm.State[SpeedParams]):
        Params = FasterParams

    class Child(Drive):  # no argument of its own: the base's Params
        pass

    class Wrong(Drive):
        Params = OtherParams

    registry = fsm.Registry()
    registry.add_state(Faster)
    registry.add_state(Child)
    assert Child.Params is SpeedParams
    with pytest.raises(fsm.RegistrationError, match="Wrong"):
        registry.add_state(Wrong)


P = TypeVar("P", bound=SpeedParams)


def test_a_generic_base_passes_its_argument_on() -> None:
    class Base(fsm.State[P]):
        pass

    class Concrete(Base[FasterParams]):
        pass

    assert Base.Params is fsm.StateParams and Base.params_argument is None
    assert Concrete.Params is FasterParams
    fsm.Registry().add_state(Concrete)


def test_transitions_and_conditions_derive_theirs_too() -> None:
    class NearParams(fsm.TransitionParams):
        limit: float = 1.0

    class HotParams(fsm.ConditionParams):
        limit: float = 1.0

    class Near(fsm.Transition[NearParams]):
        def check(self, ctx: fsm.Context) -> bool:
            return True

    class Hot(fsm.Condition[HotParams]):
        def holds(self, ctx: fsm.Context) -> bool:
            return True

    class BadHot(fsm.Condition[HotParams]):
        Params = fsm.ConditionParams

    assert Near.Params is NearParams and Hot.Params is HotParams
    registry = fsm.Registry()
    registry.add_transition(Near)
    registry.add_condition(Hot)
    with pytest.raises(fsm.RegistrationError, match="BadHot"):
        registry.add_condition(BadHot)


def test_every_builtin_type_agrees() -> None:
    registry = fsm.Registry.with_builtins()
    tables: list[dict[str, Any]] = [registry.states, registry.transitions, registry.conditions]
    assert all(cls.params_argument is None or issubclass(cls.Params, cls.params_argument)
               for table in tables for cls in table.values())

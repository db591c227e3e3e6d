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
        def holds(self, ctx: fsm.Context) -> bool:
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


# -- Transition.check is renamed holds: the old name works for one release, with a warning where the class is -------
def test_a_transition_that_still_defines_check_warns_where_it_is_defined_and_still_fires() -> None:
    with pytest.warns(DeprecationWarning, match=r"Old: Transition.check\(ctx\) is renamed holds\(ctx\)") as caught:
        class Old(fsm.Transition[fsm.TransitionParams]):
            def check(self, ctx: fsm.Context) -> bool:
                return bool(ctx.vars.get("go"))
    assert [w.filename for w in caught] == [__file__]  # the class statement, not the runtime
    builtins = fsm.Registry.with_builtins()
    registry = fsm.Registry()
    registry.add_transition(Old)
    registry.add_state(builtins.states["SetVar"])
    registry.add_state(builtins.states["Final"])
    machine = fsm.load({"initial": "a", "vars": {"go": 0},
                        "states": [{"id": "a", "type": "SetVar", "assign": {"go": "1"}},
                                   {"id": "end", "type": "Final"}],
                        "transitions": [{"type": "Old", "from": "a", "to": "end"}]}, registry=registry)
    assert fsm.run(machine, max_ticks=5).outcome == "succeeded"
    assert Old.holds is Old.check


def test_the_new_name_gives_no_warning_and_the_old_call_answers_like_holds(recwarn: pytest.WarningsRecorder) -> None:
    class New(fsm.Transition[fsm.TransitionParams]):
        def holds(self, ctx: fsm.Context) -> bool:
            return True

    assert not [w for w in recwarn if issubclass(w.category, DeprecationWarning)]
    with pytest.warns(DeprecationWarning, match="renamed holds"):
        class Older(New):
            def check(self, ctx: fsm.Context) -> bool:  # an old-style override below a new-style class
                return super().check(ctx) and False

    machine = fsm.load({"initial": "a", "states": [{"id": "a", "type": "Final"}]})
    a = machine.state("a")
    new = New(fsm.TransitionParams.model_validate({"type": "New", "from": "a", "to": "a"}), a, a)
    with pytest.warns(DeprecationWarning, match="call holds"):
        assert new.check(machine.ctx) is True
    older = Older(fsm.TransitionParams.model_validate({"type": "Older", "from": "a", "to": "a"}), a, a)
    with pytest.warns(DeprecationWarning, match="call holds"):
        assert older.holds(machine.ctx) is False

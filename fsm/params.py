"""The pydantic base models of state and transition parameters: strict, no unknown keys, no NaN."""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, WithJsonSchema, field_validator

#: An element id: any non-empty text without "/" (the path separator); UMLet names may contain spaces.
ID_PATTERN = r"^[^/]+$"


def _integral(value: Any) -> Any:
    """JSON has one number type: ``2.0`` is the integer 2 (as JSON Schema's "integer" says), ``2.5`` is not."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


#: An integer parameter that accepts ``2.0`` like JSON Schema does; use it for ``int`` fields of Params.
Int = Annotated[int, BeforeValidator(_integral)]


class ParamsBase(BaseModel):
    """Common configuration: unknown keys are errors, strings are not numbers, NaN and infinity are refused."""

    model_config = ConfigDict(
        extra="forbid",
        strict=True,
        allow_inf_nan=False,
        populate_by_name=True,
        frozen=True,
        validate_default=False,
    )

    @field_validator("*", mode="before")
    @classmethod
    def _no_null(cls, value: Any) -> Any:
        """``null`` is never a parameter's value: an optional parameter is left out to get its default
        (the generated JSON Schema says the same: no field there accepts null)."""
        if value is None:
            raise ValueError("null is not allowed here; leave the key out to get its default")
        return value


#: A condition object (``{"type": "SignalHigh", ...}``); checked against the registered condition types by the
#: loader, and in the generated schema a reference to their union.
ConditionField = Annotated[dict[str, Any], WithJsonSchema({"type": "object", "x-condition": True})]
#: A variable name an action may assign: letters (any script), digits and _, not starting with a digit.
VAR_PATTERN = r"^[^\W\d]\w*$"
#: The value of one assignment: an expression (text) or a constant number or true/false.
Assigned = bool | int | float | str
#: ``{"variable": value or expression, ...}``, run in the order written.
Assignments = Annotated[dict[Annotated[str, Field(pattern=VAR_PATTERN)], Assigned], Field(min_length=1)]


class StateSet(ParamsBase):
    """What a state assigns to blackboard variables when it is entered and when it is left."""

    on_enter: Assignments | None = Field(
        default=None, description="Assigned on entry, before the state's own on_enter: {\"var\": \"expression\"}.")
    on_exit: Assignments | None = Field(
        default=None, description="Assigned on exit, after the state's own on_exit: {\"var\": \"expression\"}.")


class StateParams(ParamsBase):
    """Fields every state element has; a state type's own ``Params`` subclasses this."""

    id: str = Field(min_length=1, pattern=ID_PATTERN, description="Unique name of the state in its machine.")
    type: str = Field(description="Registered state type.")
    description: str | None = Field(default=None, description="Free text for people.")
    set: StateSet | None = Field(default=None, description="Variables assigned on entry and exit (UML entry/exit).")
    layout: dict[str, Any] | None = Field(default=None, description="Diagram layout (x, y, w, h); ignored at run time.")


class TransitionParams(ParamsBase):
    """Fields every transition element has; a transition type's own ``Params`` subclasses this."""

    type: str = Field(description="Registered transition type.")
    from_: str = Field(alias="from", min_length=1, description="Id of the source state.")
    to: str = Field(min_length=1, description="Id of the target state.")
    priority: Int = Field(
        default=0, description="Higher is checked first; equal priorities keep declaration order."
    )
    preempt: bool = Field(
        default=False,
        description="Checked before the source state is ticked (a monitor); outermost level first.",
    )
    guard: str | ConditionField | None = Field(
        default=None, description="Must also hold for the transition to fire: an expression or a condition object.")
    set: Assignments | None = Field(
        default=None, description="The transition's action: variables assigned while firing, in order.")
    description: str | None = Field(default=None, description="Free text for people.")
    layout: dict[str, Any] | None = Field(default=None, description="Diagram layout (points); ignored at run time.")


class ConditionParams(ParamsBase):
    """Fields every condition object has; a condition type's own ``Params`` subclasses this."""

    type: str = Field(description="Registered condition type.")

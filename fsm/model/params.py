"""The pydantic base models of state and transition parameters: strict, no unknown keys, no NaN."""

from __future__ import annotations

from typing import Annotated, Any, ClassVar, Literal, TypeVar, get_args

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    GetCoreSchemaHandler,
    WithJsonSchema,
    field_validator,
)
from pydantic_core import CoreSchema


def _finite(value: Any, depth: int = 0) -> bool:
    """No NaN or infinity anywhere in ``value`` (nested lists and objects, to a sane depth)."""
    if isinstance(value, float):
        return value - value == 0
    if depth < 64 and isinstance(value, dict):
        return all(_finite(v, depth + 1) for v in value.values())
    if depth < 64 and isinstance(value, list):
        return all(_finite(v, depth + 1) for v in value)
    return True


#: An element id: any non-empty text without "/" (the path separator); UMLet names may contain spaces.
ID_PATTERN = r"^[^/]+$"


def _integral(value: Any) -> Any:
    """JSON has one number type: ``2.0`` is the integer 2 (as JSON Schema's "integer" says), ``2.5`` is not."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


#: An integer parameter that accepts ``2.0`` like JSON Schema does; use it for ``int`` fields of Params.
Int = Annotated[int, BeforeValidator(_integral)]


#: The core schemas that wrap a field's own schema under ``"schema"`` (a default, a validator function around it).
_WRAPPERS = ("default", "function-before", "function-after", "function-wrap")


def _refuse_null(schema: Any, cls: type) -> None:
    """Drop the ``nullable`` wrapper of each field of ``cls``'s model schema (in place)."""
    node = schema
    while isinstance(node, dict) and not (node.get("type") == "model" and node.get("cls") is cls):
        node = node.get("schema")  # the model under a definitions or validator wrapper
    fields = node.get("schema", {}).get("fields", {}) if isinstance(node, dict) else {}
    for field in fields.values():
        parent = field
        while isinstance(parent.get("schema"), dict):
            inner = parent["schema"]
            if inner.get("type") == "nullable":
                parent["schema"] = inner["schema"]
                break
            if inner.get("type") not in _WRAPPERS:
                break
            parent = inner


class ParamsBase(BaseModel):
    """Common configuration: unknown keys are errors, strings are not numbers, NaN and infinity are refused."""

    model_config = ConfigDict(
        extra="forbid",
        strict=True,
        allow_inf_nan=False,
        populate_by_name=True,
        frozen=True,
        validate_default=False,
        # Each model's validator is built when first used: a run uses a few of the ~40 types, and building them
        # all cost every process (each sweep worker, each fsmctl command) about 0.1 s at import.
        defer_build=True,
    )

    @field_validator("layout", mode="after", check_fields=False)
    @classmethod
    def _finite_layout(cls, value: Any) -> Any:
        """A drawing's coordinates are numbers: NaN or infinity (which Python's JSON reader lets through) would
        break the layout of every graph drawn from the document."""
        if not _finite(value):
            raise ValueError("the layout holds NaN or infinity; coordinates are finite numbers")
        return value

    @classmethod
    def __get_pydantic_core_schema__(cls, source: type[BaseModel], handler: GetCoreSchemaHandler) -> CoreSchema:
        """``null`` is never a parameter's value: an optional parameter is left out to get its default (the
        generated JSON Schema says the same: no field there accepts null). The model's validator is built without
        the ``nullable`` branch of its fields, so pydantic-core refuses null as a wrong type, with no Python call per
        field (``fsm.model.document.problems_from_validation`` words it as "may not be null")."""
        schema = handler(source)
        _refuse_null(schema, cls)
        return schema


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
    on_complete: Assignments | None = Field(
        default=None, description="Assigned in the tick the state finishes by itself (not when it is aborted, "
                                  "times out, is skipped or restarted), once per entry.")


#: What a monitor (or a timeout) does to its owner when it fires (EEROS thesis, five behaviours).
Behavior = Literal["nothing", "abortOwner", "restartOwner", "abortCallerOfOwner", "restartCallerOfOwner"]
BEHAVIORS: tuple[str, ...] = ("nothing", "abortOwner", "restartOwner", "abortCallerOfOwner", "restartCallerOfOwner")


class MonitorParams(ParamsBase):
    """A condition watched every tick while its owner (or anything inside it) is active."""

    condition: str | ConditionField = Field(
        description="When it holds, the monitor fires: an expression or a condition object.")
    exception: str | None = Field(
        default=None, min_length=1,
        description="Id of an exception sequence (declared in 'exceptions' of this sequence or an enclosing one), "
                    "run while the owner is suspended, before the behavior applies.")
    behavior: Behavior = Field(
        default="nothing",
        description="nothing: the owner resumes; abortOwner: it finishes with outcome 'aborted'; restartOwner: it "
                    "is entered again from its start; the CallerOfOwner variants act on the enclosing state.")
    description: str | None = Field(default=None, description="Free text for people.")


class StateParams(ParamsBase):
    """Fields every state element has; a state type's own ``Params`` subclasses this."""

    id: str = Field(min_length=1, pattern=ID_PATTERN, description="Unique name of the state in its machine.")
    type: str = Field(description="Registered state type.")
    description: str | None = Field(default=None, description="Free text for people.")
    set: StateSet | None = Field(default=None, description="Variables assigned on entry and exit (UML entry/exit).")
    layout: dict[str, Any] | None = Field(default=None, description="Diagram layout (x, y, w, h); ignored at run time.")
    precondition: str | ConditionField | None = Field(
        default=None, description="Checked on entry: when false the state is skipped (nothing of it runs) and "
                                  "finishes with outcome 'precondition_failed'.")
    until: str | ConditionField | None = Field(
        default=None, description="Exit condition: the state finishes ('succeeded') in the first tick it holds, "
                                  "checked after the state's tick.")
    monitors: list[MonitorParams] | None = Field(
        default=None, min_length=1, description="Conditions watched each tick before this state is ticked, while "
                                                "it or anything inside it is active.")
    timeout: Annotated[float, Field(gt=0)] | Annotated[str, Field(min_length=1)] | None = Field(
        default=None, description="Seconds (paused and suspended time excluded) after which the timeout monitor "
                                  "fires with timeout_behavior: a number, or an expression read when the state is "
                                  "entered (\"t_grip\", \"2 * t\").")
    timeout_behavior: Behavior = Field(
        default="abortOwner", description="What the timeout does (abortOwner: outcome 'timeout').")
    timeout_exception: str | None = Field(
        default=None, min_length=1, description="Exception sequence run when the timeout fires.")
    endless: bool = Field(
        default=False, description="As a step of a sequence: it never finishes by itself, something outside ends it "
                                   "(a monitor of an enclosing sequence, a pause button, an outer transition).")

    #: The step-common keys (EEROS): allowed on every state, compiled by the loader into the state's supervisor.
    STEP_KEYS: ClassVar[tuple[str, ...]] = ("precondition", "until", "monitors", "timeout", "timeout_behavior",
                                            "timeout_exception", "endless")


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


#: A parameters model (in :func:`generic_params`).
ParamsT = TypeVar("ParamsT", bound=ParamsBase)


def generic_params(cls: type, base: type[ParamsT]) -> type[ParamsT] | None:
    """The parameters class ``cls`` names as its own generic argument (``class Drive(State[DriveParams])``:
    ``DriveParams``), a subclass of ``base``; ``None`` when its bases name none (a type variable, no argument)."""
    for origin in cls.__dict__.get("__orig_bases__", ()):
        for arg in get_args(origin):
            if isinstance(arg, type) and issubclass(arg, base):
                return arg
    return None


def adopt_generic_params(cls: type, base: type[ParamsBase]) -> None:
    """Called by a plugin base's ``__init_subclass__``: the generic argument ``cls`` names (:func:`generic_params`)
    becomes its ``params_argument`` and, unless the class declares ``Params`` itself, its ``Params``."""
    derived = generic_params(cls, base)
    if derived is not None:
        setattr(cls, "params_argument", derived)  # noqa: B010  # a ClassVar of the plugin bases, not of type
        if "Params" not in cls.__dict__:
            setattr(cls, "Params", derived)  # noqa: B010

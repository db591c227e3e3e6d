"""The rate workloads every library runs: their sizes, where a machine must be after S steps, and how many
transitions S steps fire. One rule for all libraries, so that no equivalent can count differently."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

FLAT_N = 100          # states in the flat ring (a)
FAN = 10              # nesting fan-out (b): FAN x FAN x FAN
LOAD_N = 1000         # states in the loaded document (c)


class WorkloadError(AssertionError):
    """An equivalent workload did not do what it claims."""


class Unsupported(Exception):
    """The installed version of a peer cannot express the workload."""


def expect(actual: Any, expected: Any, what: str) -> None:
    if actual != expected:
        raise WorkloadError(f"{what}: expected {expected!r}, got {actual!r}")


def flat_position(steps: int) -> str:
    return f"s{steps % FLAT_N}"


def nested_position(steps: int) -> str:
    return f"c{steps // (FAN * FAN) % FAN}/m{steps // FAN % FAN}/l{steps % FAN}"


def nested_transitions(steps: int) -> int:
    """Transitions fired by ``steps`` ticks from the start: a leaf transition each tick, plus a
    ``Finished`` of the middle level every FAN ticks, plus one of the root level every FAN**2 ticks."""
    return steps + steps // FAN + steps // (FAN * FAN)


@dataclass(frozen=True)
class Workload:
    """A rate workload: ``position(S)`` is the active leaf after S steps ("s7", "c1/m2/l3"),
    ``transitions(S)`` the transitions fired by then; ``marks`` are the step counts checked before
    timing (every level boundary); ``cycle`` is the number of leaves in one round of the ring."""

    name: str
    position: Callable[[int], str]
    transitions: Callable[[int], int]
    marks: tuple[int, ...]
    cycle: int

    def fired(self, steps: int, n: int) -> int:
        """Transitions fired by the ``n`` steps after the first ``steps``."""
        return self.transitions(steps + n) - self.transitions(steps)


FLAT = Workload("flat", flat_position, lambda steps: steps, (1, FLAT_N - 1, FLAT_N, FLAT_N + 1), FLAT_N)
NESTED = Workload("nested", nested_position, nested_transitions,
                  (1, FAN - 1, FAN, FAN + 1, FAN * FAN, FAN ** 3, FAN ** 3 + FAN + 1), FAN ** 3)
WORKLOADS: dict[str, Workload] = {"flat": FLAT, "nested": NESTED}

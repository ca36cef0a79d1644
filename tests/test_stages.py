"""The driver: stages begin once, advance chunk by chunk, hooks in order, resume mid-stage."""

from __future__ import annotations

from dataclasses import dataclass, field

from grainfrac.stages import Driver, DriverState, Hooks


@dataclass
class CountState:
    start_time: float = 0.0
    chunks: int = 0


@dataclass
class Count:
    """A stage that takes ``n`` chunks and logs every call."""

    kind: str
    n: int
    log: list
    periodic_snapshots: bool = False
    state: CountState = field(default_factory=CountState)

    def begin(self, world) -> None:
        self.log.append(f"begin {self.kind}")

    def advance(self, world) -> None:
        self.state.chunks += 1
        self.log.append(f"advance {self.kind}")

    def finished(self) -> bool:
        return self.state.chunks >= self.n

    def fraction(self) -> float:
        return self.state.chunks / self.n


class Log(Hooks):
    def __init__(self, log: list):
        self.log = log

    def after_chunk(self, stage) -> None:
        self.log.append("after_chunk")

    def after_stage(self, stage) -> None:
        self.log.append(f"after_stage {stage.kind}")

    def between_chunks(self) -> None:
        self.log.append("between")

    def at_end(self) -> None:
        self.log.append("end")


def test_stages_run_in_order_with_the_hooks_between_chunks():
    log: list[str] = []
    driver = Driver([Count("a", 1, log), Count("b", 2, log)], world=None, hooks=Log(log))
    driver.execute()
    assert log == ["begin a", "advance a", "after_chunk", "after_stage a",
                   "begin b", "advance b", "after_chunk", "between",
                   "advance b", "after_chunk", "after_stage b", "end"]
    assert driver.state == DriverState(stage_index=2, begun=False, done=True)
    assert driver.current is None


def test_a_resumed_driver_continues_the_stage_it_was_in_without_beginning_it_again():
    log: list[str] = []
    b = Count("b", 3, log, state=CountState(chunks=1))
    driver = Driver([Count("a", 1, log), b], world=None,
                    state=DriverState(stage_index=1, begun=True))
    driver.execute()
    assert log == ["advance b", "advance b"]
    assert b.state.chunks == 3 and driver.state.done

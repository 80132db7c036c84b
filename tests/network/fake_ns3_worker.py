"""A stand-in for the ns-3 process (``swarmgames.network.ns3_worker``) that aborts as ns-3 does.

It answers the same requests without ns-3: every robot is a 1-hop neighbour of every other,
and nothing is ever sent. When a ``step`` reaches ``SWARMGAMES_FAKE_NS3_ABORT_S`` seconds of
its clock, it writes the lines ns-3 3.44 wrote when it aborted in ``PhyEntity::
StartReceivePreamble`` (docs/ns3.md, "Known ns-3 faults"), with a time stamp 0.25 s before
it, and ends itself with SIGABRT, as ``std::terminate`` does. With
``SWARMGAMES_FAKE_NS3_ONCE`` set to a file name, only the first run aborts: the one that
creates that file. ``SWARMGAMES_FAKE_NS3_SAY`` is written to
standard error at start, beside a line of cppyy's chatter.

Run as ``python -m tests.network.fake_ns3_worker FD PARENT_PID``.
"""

from __future__ import annotations

import os
import sys
from multiprocessing.connection import Connection

import numpy as np

from swarmgames.lifetime import end_with
from swarmgames.network.ns3_worker import serve

ABORT = (
    'NS_ASSERT failed, cond="!m_wifiPhy->m_currentEvent", +{t:.9f}s 10 '
    "file=/gcl-builds/src/wifi/model/phy-entity.cc, line=490\n"
    "NS_FATAL, terminating\n"
    "terminate called without an active exception\n"
)


class FakeServer:
    def __init__(self) -> None:
        self.abort_ns = round(float(os.environ.get("SWARMGAMES_FAKE_NS3_ABORT_S", "inf")) * 1e9)
        self.now_ns = 0
        self.n = 0
        self.scenario = 0
        self.ops = {
            "hello": self.hello,
            "build": self.build,
            "step": self.step,
            "tables": self.tables,
            "now": self.now,
            "destroy": lambda scenario: None,
        }

    def hello(self) -> str:
        say = os.environ.get("SWARMGAMES_FAKE_NS3_SAY")
        if say:
            sys.stderr.write(f"Failed to materialize symbols: {{ (main, {{ _ZN3ns3 }}) }}\n{say}\n")
            sys.stderr.flush()
        return "fake"

    def build(self, positions, radio, olsr, run, key) -> int:
        self.n, self.now_ns = len(positions), 0
        self.scenario += 1
        return self.scenario

    def step(self, scenario, stop_ns, positions) -> None:
        if stop_ns >= self.abort_ns and self._first():
            sys.stderr.write(ABORT.format(t=self.abort_ns / 1e9 - 0.25))
            sys.stderr.flush()
            os.abort()
        self.now_ns = max(self.now_ns, int(stop_ns))

    @staticmethod
    def _first() -> bool:
        flag = os.environ.get("SWARMGAMES_FAKE_NS3_ONCE")
        if not flag:
            return True
        try:
            open(flag, "x").close()
        except FileExistsError:
            return False
        return True

    def tables(self, scenario):
        owner, dest = np.divmod(np.arange(self.n * self.n), self.n)
        keep = owner != dest
        owner, dest = owner[keep].astype(np.int32), dest[keep].astype(np.int32)
        return owner, dest, dest.copy(), np.ones(owner.size, dtype=np.int16)

    def now(self, scenario) -> float:
        return self.now_ns / 1e9


if __name__ == "__main__":
    fd, parent = (int(a) for a in sys.argv[1:3])
    end_with(parent)
    serve(Connection(fd), FakeServer())

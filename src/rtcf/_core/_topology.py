"""The data flow of every lane: the graph over this process's components and the others'.

A runner of one lane (a worker process of its own) knows the components loaded in
the other lanes' processes as nodes and members only (``set_foreign``); the order,
the lanes and each lane's steps (updates and handovers) are computed over all of
them, so that every lane's process agrees on them. The graph is built on demand and
dropped when what it is built from changes (:meth:`Topology.invalidate`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from ._components import Components
from ._errors import ConfigurationError, RtcfError
from ._graph import Graph, GraphNode, build_graph
from ._lane_names import MAIN_LANE
from ._lanes import Connection, Lane, Member, Step, lane_steps, lanes_of
from ._settings import RunnerSettings


class Topology:
    """The resolved data-flow graph of every lane's components, and their lanes."""

    def __init__(self, components: Components, settings: RunnerSettings, name: str) -> None:
        self._components = components
        self._settings = settings
        self._name = name  # the runner's, for its messages
        # what this runner knows of the components loaded in the other lanes' processes
        self.foreign_nodes: list[GraphNode] = []
        self.foreign_members: list[Member] = []
        self._mirror: set[str] = set()  # topics the main lane receives for a trace
        self._shared_topics: set[str] = set()  # written in several lanes
        self._graph: Graph | None = None

    def set_foreign(
        self, nodes: Sequence[GraphNode], members: Sequence[Member], mirror: Iterable[str]
    ) -> None:
        self.foreign_nodes = list(nodes)
        self.foreign_members = list(members)
        self._mirror = set(mirror)

    def invalidate(self) -> None:
        self._graph = None

    def count(self) -> int:
        """How many components every lane holds, this process's and the others'."""
        return len(self._components.entries) + len(self.foreign_members)

    def members(self) -> list[Member]:
        """Every lane's members: this process's, then the others'."""
        return self._components.members() + self.foreign_members

    def lanes(self) -> dict[str, Lane]:
        """Every lane with its members in the data-flow order, main first."""
        return lanes_of(self.members(), self.graph.order)

    def foreign_lane(self, name: str) -> str:
        return next((m.lane for m in self.foreign_members if m.name == name), MAIN_LANE)

    @property
    def graph(self) -> Graph:
        """The resolved data-flow graph (built on demand after loads and unloads): of
        every lane's components, this process's and the others'."""
        if self._graph is None:
            loaded = self._components.entries
            members = self.members()
            kinds = lanes_of(members, [])  # a lane that mixes rates is an error here
            let = {name for name, lane in kinds.items() if lane.let}
            graph = build_graph(
                self._components.graph_nodes() + self.foreign_nodes, let_lanes=let
            )
            lanes = {m.name: m.lane for m in members}
            fallbacks = self._components.fallbacks()
            for fb, primary in fallbacks.items():  # right after what it stands in for
                graph.order.insert(graph.order.index(primary) + 1, fb)
            for name, entry in loaded.items():
                fb = entry.spec.policy.fallback
                if fb and fb not in loaded and lanes.get(fb, lanes[name]) != lanes[name]:
                    raise ConfigurationError(
                        f"component {name!r}: its fallback {fb!r} is in lane {lanes[fb]!r}, "
                        f"not in its own lane {lanes[name]!r}: a fallback writes the outputs "
                        "of the component it stands in for, so put both in one lane"
                    )
            written: dict[str, set[str]] = {}
            for node in graph.nodes:
                for port in node.outputs:
                    written.setdefault(port.topic, set()).add(lanes.get(node.name, MAIN_LANE))
            # (several producers of a topic someone reads are refused by the graph; one
            # written in several lanes that no one reads is not traced)
            self._shared_topics = {t for t, where in written.items() if len(where) > 1}
            wait_policy = self._settings.wait_policy
            if len(kinds) > 1 and wait_policy != "absolute":
                raise ConfigurationError(
                    f"runner {self._name!r}: wait_policy {wait_policy!r} does not "
                    "go with lanes: lanes keep one time grid (wait_policy absolute)"
                )
            self._graph = graph
        return self._graph

    def stopping_order(self) -> list[str]:
        """The order, or the load order when the graph does not resolve: what stops
        components (in reverse) must run whatever the graph says."""
        try:
            return self.graph.order
        except RtcfError:
            return list(self._components.entries)

    def lane_plan(self, lane: str | None) -> list[Step]:
        """The steps of ``lane`` (None: the main lane in a runner of every lane)."""
        members = {m.name: m for m in self.members()}
        return self.steps(lane, self.lanes(), members)

    def steps(
        self, lane: str | None, lanes: dict[str, Lane], members: dict[str, Member]
    ) -> list[Step]:
        edges = self.graph.edges
        connections = [Connection(e.topic, e.producer.component, e.consumer.component)
                       for e in edges]
        producers = {
            p.topic: n.name
            for n in self._components.graph_nodes() + self.foreign_nodes
            for p in n.outputs
        }
        mirror = {  # (a topic written in several lanes that no one reads: not traced)
            t: producers[t] for t in sorted(self._mirror)
            if t in producers and t not in self._shared_topics
        }
        return lane_steps(
            lane or MAIN_LANE, lanes, members, self.graph.order, connections, mirror
        )

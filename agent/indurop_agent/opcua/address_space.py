"""address_space.py -- the server's own nodes (docs/opcua.md "The address space"):

- the running layout's tree under Objects, named by the .glb paths (namespaces, structs, arrays of
  structs and their elements as objects; scalars as variables, arrays of scalars as array
  variables), every node's NodeId the path as a string in our namespace
  (ns=<ns>;s=PLC_ROBOT.PLC_OUT.Cycles); a read reads the variable segment;
- Controller (s=@Controller): the running set, its id, the layout hash, generation, uptime, basic
  period, counters (properties); Modules and Dispatchers with each one's figures (period, priority,
  state, runs, overruns, missed, jitter and execution p50/p99/max) from irpd's `modules` and `stats`,
  as GET /modules and /jitter read them; Alarms, the notifier of the alarm events (alarms.py);
- every variable's `Forced` property (s=<path>@Forced, a Boolean): irpd holds it (an array: one of
  its elements) forced (docs/forcing.md), updated with the status; ForcesActive counts the forces.

When the layout changes (a hot swap, an online change), `apply` removes the nodes whose variable
went or changed type or shape, adds the new ones and emits a GeneralModelChangeEvent; nodes of
unchanged variables stay as they are, so monitored items on them go on.
"""

from __future__ import annotations

from asyncua import Server, ua
from asyncua.common.node import Node

from .values import Obj, Var, Variables, tree

NAMESPACE = "urn:indurop:controller"
CONTROLLER = "@Controller"
STATUS_PROPERTIES = {  # property -> (irpd status field, type)
    "Set": ("set", ua.VariantType.String),
    "SetId": ("set_id", ua.VariantType.String),
    "Generation": ("generation", ua.VariantType.UInt64),
    "Running": ("running", ua.VariantType.Boolean),
    "UptimeSeconds": ("uptime_ns", ua.VariantType.Double),
    "BasicPeriodNs": ("basic_period_ns", ua.VariantType.Int64),
    "Cycles": ("cycles", ua.VariantType.UInt64),
    "Overruns": ("overruns", ua.VariantType.UInt64),
    "Missed": ("missed", ua.VariantType.UInt64),
    "StoppedByFault": ("stopped_by_fault", ua.VariantType.String),
    "ForcesActive": ("forces", ua.VariantType.UInt32),
}
FIGURES = {  # variable -> (path into the timing record, type)
    "PeriodNs": (("period_ns",), ua.VariantType.Int64),
    "Priority": (("priority",), ua.VariantType.Int32),
    "State": (("state",), ua.VariantType.String),
    "Runs": (("runs",), ua.VariantType.UInt64),
    "Overruns": (("overruns",), ua.VariantType.UInt64),
    "Missed": (("missed",), ua.VariantType.UInt64),
    "JitterP50Ns": (("jitter_ns", "p50"), ua.VariantType.Double),
    "JitterP99Ns": (("jitter_ns", "p99"), ua.VariantType.Double),
    "JitterMaxNs": (("jitter_ns", "max"), ua.VariantType.Double),
    "ExecP50Ns": (("exec_ns", "p50"), ua.VariantType.Double),
    "ExecP99Ns": (("exec_ns", "p99"), ua.VariantType.Double),
    "ExecMaxNs": (("exec_ns", "max"), ua.VariantType.Double),
}
VERB_ADDED, VERB_DELETED = 1, 2  # ModelChangeStructureVerbMask


def _default(vtype: ua.VariantType):
    return {ua.VariantType.String: "", ua.VariantType.Boolean: False, ua.VariantType.Double: 0.0}.get(vtype, 0)


def _figure(record: dict, where: tuple[str, ...]):
    value = record
    for key in where:
        value = value.get(key) if isinstance(value, dict) else None
    return value


class Space:
    def __init__(self, server: Server, variables: Variables, min_sampling_ms: float):
        self.server = server
        self.variables = variables
        self.min_sampling_ms = min_sampling_ms
        self.ns = 0
        self.nodes: dict[str, Obj | Var] = {}  # the layout's nodes now, by path
        self.layout_hash = ""
        self._by_id: dict[ua.NodeId, Var] = {}
        self._properties: dict[str, Node] = {}
        self._figures: dict[tuple[str, str], dict[str, Node]] = {}  # (Modules|Dispatchers, name) -> nodes
        self._forced: dict[str, tuple[Node, bool]] = {}  # variable path -> its Forced property, its value
        self._model_change = None
        self.controller: Node | None = None
        self.alarms_node: Node | None = None

    def nodeid(self, path: str) -> ua.NodeId:
        return ua.NodeId(path, self.ns)

    def var_of(self, nodeid: ua.NodeId) -> Var | None:
        return self._by_id.get(nodeid)

    @property
    def variables_by_path(self) -> dict[str, Var]:
        return {p: n for p, n in self.nodes.items() if isinstance(n, Var)}

    # ---- the fixed part -----------------------------------------------------------------------
    async def init(self) -> None:
        self.ns = await self.server.register_namespace(NAMESPACE)
        objects = self.server.nodes.objects
        self.controller = await objects.add_object(self.nodeid(CONTROLLER), ua.QualifiedName("Controller", self.ns))
        for name, (_, vtype) in STATUS_PROPERTIES.items():
            self._properties[name] = await self.controller.add_property(
                self.nodeid(f"{CONTROLLER}.{name}"), ua.QualifiedName(name, self.ns), ua.Variant(_default(vtype), vtype)
            )
        self._properties["LayoutHash"] = await self.controller.add_property(
            self.nodeid(f"{CONTROLLER}.LayoutHash"),
            ua.QualifiedName("LayoutHash", self.ns),
            ua.Variant("", ua.VariantType.String),
        )
        for folder in ("Modules", "Dispatchers", "Alarms"):
            node = await self.controller.add_object(
                self.nodeid(f"{CONTROLLER}.{folder}"), ua.QualifiedName(folder, self.ns)
            )
            if folder == "Alarms":
                self.alarms_node = node
        self._model_change = await self.server.get_event_generator(
            ua.ObjectIds.GeneralModelChangeEventType, self.server.nodes.server
        )
        # asyncua types the field by its DataType's NodeId; on the wire it is an array of
        # ModelChangeStructureDataType as ExtensionObjects
        self._model_change.event.data_types["Changes"] = ua.VariantType.ExtensionObject

    # ---- the layout's tree --------------------------------------------------------------------
    async def apply(self, layout: dict | None, layout_hash: str) -> tuple[int, int]:
        """Makes the nodes the layout holds (None: none): (nodes removed, nodes added)."""
        new = tree(layout) if layout else {}
        old = self.nodes
        gone = [p for p, n in old.items() if p not in new or new[p].signature != n.signature]
        added = [p for p, n in new.items() if p not in old or old[p].signature != n.signature]
        changes = []
        for p in sorted(gone, key=lambda p: -p.count(".") - p.count("[")):  # children first
            node = self.server.get_node(self.nodeid(p))
            if p in self._forced:
                await self.server.delete_nodes([self._forced.pop(p)[0]], recursive=False)
            await self.server.delete_nodes([node], recursive=False)
            self._by_id.pop(self.nodeid(p), None)
            changes.append(ua.ModelChangeStructureDataType(Affected=self.nodeid(p), Verb=VERB_DELETED))
        for p in added:  # tree() gives parents first
            n = new[p]
            parent = self.server.get_node(self.nodeid(n.parent)) if n.parent else self.server.nodes.objects
            name = ua.QualifiedName(n.name, self.ns)
            if isinstance(n, Obj):
                await parent.add_object(self.nodeid(p), name)
                kind = ua.NodeId(ua.ObjectIds.BaseObjectType)
            else:
                await self._add_variable(parent, n, name)
                kind = ua.NodeId(ua.ObjectIds.BaseDataVariableType)
            changes.append(ua.ModelChangeStructureDataType(Affected=self.nodeid(p), AffectedType=kind, Verb=VERB_ADDED))
        self.nodes = new
        self._by_id = {self.nodeid(p): n for p, n in new.items() if isinstance(n, Var)}
        self.layout_hash = layout_hash
        await self._properties["LayoutHash"].write_value(ua.Variant(layout_hash, ua.VariantType.String))
        if changes and old:  # the first build is no change
            self._model_change.event.Changes = changes
            message = f"layout {layout_hash[:12]}: {len(gone)} nodes removed, {len(added)} added"
            try:
                await self._model_change.trigger(message=message)
            except Exception as e:  # the nodes are right whatever happens to the event
                print(f"indurop-opcua: the model change event: {type(e).__name__}: {e}", flush=True)
        return len(gone), len(added)

    async def _add_variable(self, parent: Node, var: Var, name: ua.QualifiedName) -> None:
        empty = 0 if var.variant != ua.VariantType.Boolean else False
        initial = ua.Variant([empty] * len(var.leaves), var.variant) if var.dims else ua.Variant(empty, var.variant)
        node = await parent.add_variable(self.nodeid(var.path), name, initial, datatype=ua.NodeId(var.variant.value))
        nid = node.nodeid
        attrs = [
            (ua.AttributeIds.Description, ua.Variant(ua.LocalizedText(var.description))),
            (ua.AttributeIds.ValueRank, ua.Variant(len(var.dims) if var.dims else -1, ua.VariantType.Int32)),
            (ua.AttributeIds.MinimumSamplingInterval, ua.Variant(self.min_sampling_ms, ua.VariantType.Double)),
            (
                ua.AttributeIds.AccessLevel,
                ua.Variant(ua.AccessLevel.CurrentRead.mask | ua.AccessLevel.CurrentWrite.mask, ua.VariantType.Byte),
            ),
            (
                ua.AttributeIds.UserAccessLevel,
                ua.Variant(ua.AccessLevel.CurrentRead.mask | ua.AccessLevel.CurrentWrite.mask, ua.VariantType.Byte),
            ),
        ]
        if var.dims:
            attrs.append((ua.AttributeIds.ArrayDimensions, ua.Variant(list(var.dims), ua.VariantType.UInt32)))
        for attr, value in attrs:
            await self.server.write_attribute_value(nid, ua.DataValue(value), attr)
        self.server.iserver.set_attribute_value_callback(nid, lambda _nid, _attr, v=var: self.variables.data_value(v))
        forced = await node.add_property(
            self.nodeid(f"{var.path}@Forced"),
            ua.QualifiedName("Forced", self.ns),
            ua.Variant(False, ua.VariantType.Boolean),
        )
        self._forced[var.path] = (forced, False)

    async def update_forces(self, forced: set[str]) -> None:
        """Each variable's Forced property: one of its leaves is among the forced paths."""
        for path, (node, was) in list(self._forced.items()):
            var = self.nodes.get(path)
            now = isinstance(var, Var) and any(leaf in forced for leaf in var.leaves)
            if now != was:
                await node.write_value(ua.Variant(now, ua.VariantType.Boolean))
                self._forced[path] = (node, now)

    # ---- the controller's figures ------------------------------------------------------------
    async def update_status(self, status: dict) -> None:
        for name, (key, vtype) in STATUS_PROPERTIES.items():
            value = status.get(key)
            if key == "uptime_ns" and value is not None:
                value = value / 1e9
            if value is None:
                value = _default(vtype)
            await self._properties[name].write_value(ua.Variant(value, vtype))

    async def update_figures(self, folder: str, records: list[dict]) -> None:
        """Modules (irpd `modules`) or Dispatchers (`stats` executors, by executor): an object per
        record, made when it first appears and removed when it leaves the set."""
        key_of = (lambda r: r.get("executor")) if folder == "Dispatchers" else (lambda r: r.get("name"))
        seen = set()
        for record in records:
            name = str(key_of(record) or "")
            if not name:
                continue
            seen.add(name)
            nodes = self._figures.get((folder, name))
            if nodes is None:
                nodes = await self._figure_object(folder, name)
            for figure, (where, vtype) in FIGURES.items():
                value = _figure(record, where)
                if value is None:
                    value = _default(vtype)
                try:
                    await nodes[figure].write_value(ua.Variant(value, vtype))
                except (OverflowError, TypeError, ValueError):
                    pass  # a figure out of its type's range: kept as it was
        for folder_, name in [k for k in self._figures if k[0] == folder and k[1] not in seen]:
            await self.server.delete_nodes(
                [self.server.get_node(self.nodeid(f"{CONTROLLER}.{folder_}.{name}"))], recursive=True
            )
            del self._figures[(folder_, name)]

    async def _figure_object(self, folder: str, name: str) -> dict[str, Node]:
        base = f"{CONTROLLER}.{folder}.{name}"
        parent = self.server.get_node(self.nodeid(f"{CONTROLLER}.{folder}"))
        obj = await parent.add_object(self.nodeid(base), ua.QualifiedName(name, self.ns))
        nodes = {}
        for figure, (_, vtype) in FIGURES.items():
            nodes[figure] = await obj.add_variable(
                self.nodeid(f"{base}.{figure}"), ua.QualifiedName(figure, self.ns), ua.Variant(_default(vtype), vtype)
            )
        self._figures[(folder, name)] = nodes
        return nodes

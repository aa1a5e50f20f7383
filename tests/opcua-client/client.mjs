// client.mjs -- node-opcua's client (an OPC UA stack independent of the server's asyncua), driven by
// tests/python/opcua/test_node_opcua.py: one JSON command a line on stdin, one JSON answer a line on stdout.
//
//   node client.mjs PKI_FOLDER     (node-opcua's own certificate store: made there at the first start)
//   {"op": "connect", "id": "a", "url": "opc.tcp://127.0.0.1:PORT/", "policy": "Basic256Sha256",
//    "mode": "SignAndEncrypt", "user": "oper", "password": "...", "server_cert": "FILE.der"}  -> {"ok": true} | {"error": ...}
//    ("user": null: anonymous; with "force_anonymous": true, sent even when the server offers no such token;
//     "force_none": true with policy and mode "None": a session asked for over None though no endpoint offers it)
//   {"op": "browse", "id": "a", "root": "ns=2;s=PLC_ROBOT"}       -> {"variables": [{nodeId, dataType, valueRank, arrayDimensions}]}
//   {"op": "read", "id": "a", "nodes": ["ns=2;s=..."]}            -> {"values": [{value, status}]}
//   {"op": "write", "id": "a", "node": "...", "type": "Int16", "value": 1}    -> {"status": "Good"}
//   {"op": "subscribe", "id": "a", "node": "...", "sampling": 10, "publishing": 100, "queue": 100}  -> {"item": N}
//   {"op": "events", "id": "a", "fields": ["EventType", ...]}     -> {"item": N}  (the Server object's events)
//   {"op": "condition_refresh", "id": "a"}                        -> {"status": "Good"}  (ConditionRefresh of its subscription)
//   {"op": "notifications", "id": "a", "item": N}                 -> {"values": [{value, source, status}], "events": [...]}
//   {"op": "many_items", "id": "a", "node": "...", "count": 2000, "per_call": 400}  -> {"statuses": {"Good": n, ...}}
//   {"op": "disconnect", "id": "a"}, {"op": "quit"}
// node-opcua's own certificate is PKI_FOLDER/own/certs/client_certificate.pem (made at the first connect).
import fs from "node:fs";
import readline from "node:readline";

// node-opcua logs with console.log: to stderr, so that stdout carries the answers alone
console.log = (...args) => console.error(...args);
const { OPCUACertificateManager } = await import("node-opcua-certificate-manager");
const opcua = (await import("node-opcua-client")).default;

const {
  AttributeIds,
  ClientMonitoredItem,
  ClientSubscription,
  DataType,
  MessageSecurityMode,
  OPCUAClient,
  SecurityPolicy,
  TimestampsToReturn,
  UserTokenType,
  Variant,
  constructEventFilter,
  resolveNodeId,
  BrowseDirection,
  NodeClass,
} = opcua;

const pki = process.argv[2];
const manager = new OPCUACertificateManager({ rootFolder: pki, automaticallyAcceptUnknownCertificate: false });
await manager.initialize();
const sessions = new Map(); // id -> {client, session, subscription, items: Map}

function statusName(e) {
  const text = String(e?.message ?? e);
  const m = text.match(/Bad[A-Za-z]+/);
  return m ? m[0] : text.split("\n")[0];
}

function field(variant) {
  // an event field as JSON: NodeIds as "ns=..;i=..", LocalizedTexts as their text, structures'
  // NodeIds likewise (a model change's `affected`)
  const v = variant?.value;
  const one = (x) => {
    if (x === null || x === undefined) return null;
    if (x.identifierType !== undefined && x.namespace !== undefined) return x.toString();
    if (x.text !== undefined && x.locale !== undefined) return x.text;
    if (x.affected !== undefined) return { affected: x.affected.toString(), verb: x.verb };
    return plain(x);
  };
  return Array.isArray(v) ? v.map(one) : one(v);
}

function plain(v) {
  if (typeof v === "bigint") return Number(v);
  if (v instanceof Float32Array || v instanceof Float64Array || ArrayBuffer.isView(v)) return Array.from(v, plain);
  if (Array.isArray(v)) return v.map(plain);
  if (v && typeof v === "object" && "high" in v && "low" in v) return v.high * 2 ** 32 + (v.low >>> 0);
  return v;
}

async function connect(c) {
  if (c.server_cert) await manager.trustCertificate(fs.readFileSync(c.server_cert));
  const client = OPCUAClient.create({
    applicationName: "indurop node-opcua test",
    clientCertificateManager: manager,
    securityMode: MessageSecurityMode[c.mode],
    securityPolicy: SecurityPolicy[c.policy],
    endpointMustExist: false,
    connectionStrategy: { maxRetry: 0, initialDelay: 100, maxDelay: 200 },
    requestedSessionTimeout: 60000,
    keepSessionAlive: false,
  });
  try {
    await client.connect(c.url);
    if (c.user === null && c.force_anonymous) {
      // the server offers no anonymous token policy and node-opcua would refuse to send one: add one
      // to the endpoints it read, so that the server's own refusal is what the test sees
      for (const e of client._serverEndpoints ?? []) {
        e.userIdentityTokens = [
          ...(e.userIdentityTokens ?? []),
          { policyId: "anonymous", tokenType: UserTokenType.Anonymous },
        ];
      }
    }
    if (c.force_none) {
      // the server lists no None endpoint and node-opcua would not ask for a session over one: add
      // one to the endpoints it read (from a secured one, with its user token policies), so that
      // the server's own refusal is what the test sees
      const endpoints = client._serverEndpoints ?? [];
      const e = endpoints.find((x) => x.userIdentityTokens?.length);
      if (e) {
        endpoints.push(
          new e.constructor({
            ...e,
            securityMode: MessageSecurityMode.None,
            securityPolicyUri: SecurityPolicy.None,
            userIdentityTokens: e.userIdentityTokens.map((t) => ({ ...t, securityPolicyUri: SecurityPolicy.None })),
          }),
        );
      }
    }
    const identity =
      c.user === undefined || c.user === null
        ? { type: UserTokenType.Anonymous }
        : { type: UserTokenType.UserName, userName: c.user, password: c.password };
    const session = await client.createSession(identity);
    sessions.set(c.id, { client, session, subscription: null, items: new Map(), next: 1 });
    return { ok: true };
  } catch (e) {
    await client.disconnect().catch(() => {});
    return { error: statusName(e), message: String(e?.message ?? e).split("\n")[0] };
  }
}

async function browse(session, root) {
  const out = [];
  const walk = async (nodeId) => {
    const r = await session.browse({
      nodeId,
      browseDirection: BrowseDirection.Forward,
      referenceTypeId: "HierarchicalReferences",
      includeSubtypes: true,
      nodeClassMask: 0,
      resultMask: 63,
    });
    for (const ref of r.references ?? []) {
      const id = ref.nodeId.toString();
      if (ref.nodeClass === NodeClass.Variable) out.push(id);
      else if (ref.nodeClass === NodeClass.Object) await walk(id);
    }
  };
  await walk(root);
  const attrs = [AttributeIds.DataType, AttributeIds.ValueRank, AttributeIds.ArrayDimensions];
  const read = await session.read(out.flatMap((nodeId) => attrs.map((attributeId) => ({ nodeId, attributeId }))));
  return out.map((nodeId, i) => {
    const [type, rank, dims] = read.slice(3 * i, 3 * i + 3);
    const t = type.value.value;
    return {
      nodeId,
      dataType: t.namespace === 0 && DataType[t.value] ? DataType[t.value] : t.toString(),
      valueRank: rank.value.value,
      arrayDimensions: dims.value.value ? plain(dims.value.value) : null,
    };
  });
}

function subscription(s, publishing = 100) {
  if (!s.subscription) {
    s.subscription = ClientSubscription.create(s.session, {
      requestedPublishingInterval: publishing,
      requestedLifetimeCount: 600,
      requestedMaxKeepAliveCount: 20,
      maxNotificationsPerPublish: 0,
      publishingEnabled: true,
      priority: 1,
    });
  }
  return s.subscription;
}

async function monitor(s, nodeId, attributeId, parameters, onChange) {
  const sub = subscription(s, parameters.publishing);
  const item = ClientMonitoredItem.create(
    sub,
    { nodeId: resolveNodeId(nodeId), attributeId },
    parameters,
    TimestampsToReturn.Both,
  );
  const handle = s.next++;
  const record = { values: [], events: [] };
  s.items.set(handle, record);
  item.on("changed", (x) => onChange(record, x));
  await new Promise((resolve) => {
    item.once("initialized", resolve);
    item.once("err", resolve);
  });
  record.status = item.statusCode.name;
  return { item: handle, status: record.status, revised: item.result?.revisedSamplingInterval };
}

async function handle(c) {
  if (c.op === "connect") return connect(c);
  if (c.op === "quit") {
    for (const s of sessions.values()) await s.client.disconnect().catch(() => {});
    await manager.dispose();
    process.exit(0);
  }
  const s = sessions.get(c.id);
  if (!s) return { error: `no session ${c.id}` };
  switch (c.op) {
    case "browse":
      return { variables: await browse(s.session, c.root) };
    case "read": {
      const r = await s.session.read(c.nodes.map((nodeId) => ({ nodeId, attributeId: AttributeIds.Value })));
      return { values: r.map((dv) => ({ value: plain(dv.value?.value), status: dv.statusCode.name })) };
    }
    case "write": {
      const status = await s.session.write({
        nodeId: c.node,
        attributeId: AttributeIds.Value,
        value: { value: new Variant({ dataType: DataType[c.type], value: c.value }) },
      });
      return { status: status.name };
    }
    case "subscribe":
      return monitor(
        s,
        c.node,
        AttributeIds.Value,
        { samplingInterval: c.sampling, queueSize: c.queue ?? 100, discardOldest: true, publishing: c.publishing },
        (record, dv) =>
          record.values.push({
            value: plain(dv.value?.value),
            status: dv.statusCode.name,
            source: dv.sourceTimestamp?.getTime() ?? null,
          }),
      );
    case "events": {
      // the Server object's events, each as {field name: value} for the fields asked
      const filter = constructEventFilter(c.fields);
      return monitor(
        s,
        "ns=0;i=2253",
        AttributeIds.EventNotifier,
        { samplingInterval: 0, queueSize: 100, discardOldest: true, filter },
        (record, values) => record.events.push(Object.fromEntries(c.fields.map((f, i) => [f, field(values[i])]))),
      );
    }
    case "condition_refresh": {
      const r = await s.session.call({
        objectId: "ns=0;i=2782", // ConditionType
        methodId: "ns=0;i=3875", // ConditionType.ConditionRefresh
        inputArguments: [new Variant({ dataType: DataType.UInt32, value: s.subscription.subscriptionId })],
      });
      return { status: r.statusCode.name };
    }
    case "notifications": {
      const record = s.items.get(c.item);
      return { values: record.values, events: record.events };
    }
    case "many_items": {
      // a subscription of its own, made with the bare service (node-opcua's ClientSubscription keeps
      // only the items it made itself): its notifications wait on the server, bounded by the queues
      if (!s.bare) {
        const made = await s.session.createSubscription({
          requestedPublishingInterval: 1000,
          requestedLifetimeCount: 600,
          requestedMaxKeepAliveCount: 10,
          maxNotificationsPerPublish: 0,
          publishingEnabled: true,
          priority: 1,
        });
        s.bare = made.subscriptionId;
      }
      const sub = { subscriptionId: s.bare };
      const statuses = {};
      for (let done = 0; done < c.count; done += c.per_call) {
        const n = Math.min(c.per_call, c.count - done);
        const items = Array.from({ length: n }, (_, i) => ({
          itemToMonitor: { nodeId: resolveNodeId(c.node), attributeId: AttributeIds.Value },
          monitoringMode: 2, // Reporting
          requestedParameters: {
            clientHandle: 100000 + done + i,
            samplingInterval: 100,
            queueSize: 1,
            discardOldest: true,
          },
        }));
        try {
          const r = await s.session.createMonitoredItems({
            subscriptionId: sub.subscriptionId,
            timestampsToReturn: TimestampsToReturn.Both,
            itemsToCreate: items,
          });
          for (const x of r.results) statuses[x.statusCode.name] = (statuses[x.statusCode.name] ?? 0) + 1;
        } catch (e) {
          statuses[statusName(e)] = (statuses[statusName(e)] ?? 0) + n;
        }
      }
      return { statuses };
    }
    case "disconnect":
      await s.session.close().catch(() => {});
      await s.client.disconnect();
      sessions.delete(c.id);
      return { ok: true };
    default:
      return { error: `unknown op ${c.op}` };
  }
}

for await (const line of readline.createInterface({ input: process.stdin })) {
  if (!line.trim()) continue;
  let answer;
  try {
    answer = await handle(JSON.parse(line));
  } catch (e) {
    answer = { error: statusName(e), message: String(e?.message ?? e).split("\n")[0] };
  }
  process.stdout.write(`${JSON.stringify(answer)}\n`);
}

// A Foxglove WebSocket client that servolab did not write: Foxglove's own FoxgloveClient
// (@foxglove/ws-protocol) over the `ws` package, decoding ROS 2 CDR with Foxglove's
// independent decoder (@foxglove/rosmsg2-serialization) from the schema text the server
// advertises (parsed by @foxglove/rosmsg). servolab's tests run it as an oracle
// (tests/viewclient.py); `make view-oracle` installs its packages.
//
//   node client.mjs --url ws://127.0.0.1:PORT --subprotocol foxglove.sdk.v1 \
//       --topic /a --topic /b --count N [--timeout S] [--get-parameters a,b]
//       [--set-parameter name=jsonvalue] [--call-service /name --request-json '{...}']
//
// It prints one JSON line per event on stdout (serverInfo, advertise, subscribe, message,
// advertiseServices, parameterValues, serviceResponse, serviceCallFailure, status, error,
// close, timeout, done). It stops once every --topic has delivered --count messages and every
// requested parameter or service operation was answered: exit 0; at --timeout seconds: a
// {"op":"timeout"} line and exit 2; when the connection fails or closes first: exit 1.

// The @foxglove packages are CommonJS: import their module objects, then pick the names.
import wsProtocol from "@foxglove/ws-protocol";
import rosmsg2Serialization from "@foxglove/rosmsg2-serialization";
import rosmsg from "@foxglove/rosmsg";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;
const { MessageReader, MessageWriter } = rosmsg2Serialization;
const parseMessageDefinition = rosmsg.parse;

function usage(message) {
  process.stderr.write(`client.mjs: ${message}\n`);
  process.exit(64);
}

function parseArgs(argv) {
  const args = {
    url: undefined, subprotocol: FoxgloveClient.SUPPORTED_SUBPROTOCOL, topics: [], count: 1,
    timeout: 10, getParameters: undefined, setParameters: [], callService: undefined,
    requestJson: "{}",
  };
  for (let i = 0; i < argv.length; i++) {
    const flag = argv[i];
    const value = () => {
      if (i + 1 >= argv.length) usage(`${flag} needs a value`);
      return argv[++i];
    };
    switch (flag) {
      case "--url": args.url = value(); break;
      case "--subprotocol": args.subprotocol = value(); break;
      case "--topic": args.topics.push(value()); break;
      case "--count": args.count = Number.parseInt(value(), 10); break;
      case "--timeout": args.timeout = Number.parseFloat(value()); break;
      case "--get-parameters":
        args.getParameters = value().split(",").filter((name) => name.length > 0);
        break;
      case "--set-parameter": {
        const text = value();
        const eq = text.indexOf("=");
        if (eq <= 0) usage(`--set-parameter wants name=jsonvalue, not ${text}`);
        args.setParameters.push({ name: text.slice(0, eq), value: JSON.parse(text.slice(eq + 1)) });
        break;
      }
      case "--call-service": args.callService = value(); break;
      case "--request-json": args.requestJson = value(); break;
      default: usage(`unknown argument ${flag}`);
    }
  }
  if (!args.url) usage("--url is required");
  if (!Number.isFinite(args.count) || args.count < 0) usage("--count wants a number >= 0");
  if (!Number.isFinite(args.timeout) || args.timeout <= 0) usage("--timeout wants seconds > 0");
  return args;
}

// JSON-safe copy of a decoded message: typed arrays become plain arrays, bigints strings.
function plain(value) {
  if (typeof value === "bigint") return value.toString();
  if (ArrayBuffer.isView(value) && !(value instanceof DataView)) {
    return Array.from(value, (item) => plain(item));
  }
  if (Array.isArray(value)) return value.map((item) => plain(item));
  if (value !== null && typeof value === "object") {
    const out = {};
    for (const [key, item] of Object.entries(value)) out[key] = plain(item);
    return out;
  }
  if (typeof value === "number" && !Number.isFinite(value)) return String(value);
  return value;
}

function emit(event) {
  process.stdout.write(`${JSON.stringify(plain(event))}\n`);
}

// A JSON value made writable by MessageWriter for the definition named `type` (the first
// definition when undefined): int64/uint64 fields given as numbers or strings become bigints.
function forWriter(value, defs, type) {
  const def = type === undefined ? defs[0] : defs.find((d) => d.name === type);
  if (def === undefined || value === null || typeof value !== "object") return value;
  const out = { ...value };
  for (const field of def.definitions) {
    if (field.isConstant || !(field.name in out)) continue;
    const one = (item) => {
      if (field.isComplex) return forWriter(item, defs, field.type);
      if ((field.type === "int64" || field.type === "uint64") &&
          (typeof item === "number" || typeof item === "string")) return BigInt(item);
      return item;
    };
    out[field.name] = field.isArray && Array.isArray(out[field.name])
      ? out[field.name].map(one) : one(out[field.name]);
  }
  return out;
}

// The message definitions of a schema: ros2msg text as is; ros2srv text split at its "---"
// line (part 0 the request, part 1 the response).
function definitions(schemaEncoding, schema, part) {
  let text = schema;
  if (schemaEncoding === "ros2srv") {
    const parts = schema.split(/^---\s*$/m);
    text = parts[part] ?? "";
  } else if (schemaEncoding !== "ros2msg") {
    throw new Error(`schema encoding ${schemaEncoding} is not supported (ros2msg, ros2srv)`);
  }
  return parseMessageDefinition(text, { ros2: true });
}

// A service's request or response definition: ws-protocol's `request`/`response` objects,
// else the deprecated requestSchema/responseSchema (ros2msg text).
function serviceDefinition(service, which) {
  const part = which === "request" ? 0 : 1;
  const def = service[which];
  if (def !== undefined) {
    if (def.encoding !== "cdr") throw new Error(`service ${which} encoding ${def.encoding} is not cdr`);
    return { encoding: def.encoding, definitions: definitions(def.schemaEncoding, def.schema, part) };
  }
  const legacy = service[`${which}Schema`];
  if (legacy === undefined) throw new Error(`service ${service.name} advertises no ${which} schema`);
  return { encoding: "cdr", definitions: definitions("ros2msg", legacy, part) };
}

const args = parseArgs(process.argv.slice(2));
const ws = new WebSocket(args.url, [args.subprotocol]);
const client = new FoxgloveClient({ ws });

const received = new Map(args.topics.map((topic) => [topic, 0]));
const subscriptions = new Map(); // subscription id -> { topic, reader }
const subscribedTopics = new Set();
const pendingParameterRequests = new Set();
let serviceCall = args.callService === undefined ? undefined : { callId: 1, sent: false, done: false };
let serviceDefs;
let finished = false;

function finish(code) {
  if (finished) return;
  finished = true;
  clearTimeout(timer);
  try {
    client.close();
  } catch {
    // the socket may already be gone
  }
  // Let stdout drain before exiting.
  process.stdout.write("", () => process.exit(code));
}

function checkDone() {
  for (const count of received.values()) if (count < args.count) return;
  if (pendingParameterRequests.size > 0) return;
  if (serviceCall !== undefined && !serviceCall.done) return;
  emit({ op: "done" });
  finish(0);
}

const timer = setTimeout(() => {
  emit({ op: "timeout", received: Object.fromEntries(received) });
  finish(2);
}, args.timeout * 1000);

client.on("open", () => {
  emit({ op: "open", protocol: ws.protocol });
  if (args.getParameters !== undefined) {
    pendingParameterRequests.add("get");
    client.getParameters(args.getParameters, "get");
  }
  if (args.setParameters.length > 0) {
    pendingParameterRequests.add("set");
    client.setParameters(args.setParameters, "set");
  }
  checkDone();
});

client.on("error", (error) => {
  emit({ op: "error", error: String(error?.message ?? error) });
});

client.on("close", (event) => {
  if (finished) return;
  emit({ op: "close", code: event?.code, reason: String(event?.reason ?? "") });
  finish(1);
});

client.on("serverInfo", (info) => emit(info));
client.on("status", (status) => emit(status));

client.on("advertise", (channels) => {
  for (const channel of channels) {
    emit({
      op: "advertise", id: channel.id, topic: channel.topic, encoding: channel.encoding,
      schemaName: channel.schemaName, schemaEncoding: channel.schemaEncoding,
    });
    if (!received.has(channel.topic) || subscribedTopics.has(channel.topic)) continue;
    let reader;
    try {
      if (channel.encoding !== "cdr") throw new Error(`message encoding ${channel.encoding} is not cdr`);
      reader = new MessageReader(definitions(channel.schemaEncoding ?? "ros2msg", channel.schema, 0));
    } catch (error) {
      emit({ op: "error", topic: channel.topic, error: String(error?.message ?? error) });
      continue;
    }
    const id = client.subscribe(channel.id);
    subscribedTopics.add(channel.topic);
    subscriptions.set(id, { topic: channel.topic, reader });
    emit({ op: "subscribe", topic: channel.topic, channelId: channel.id, subscriptionId: id });
  }
});

client.on("message", ({ subscriptionId, timestamp, data }) => {
  const subscription = subscriptions.get(subscriptionId);
  if (subscription === undefined) return;
  const { topic, reader } = subscription;
  if (received.get(topic) >= args.count) return;
  let message;
  try {
    message = reader.readMessage(data);
  } catch (error) {
    emit({ op: "error", topic, error: `cannot decode: ${error?.message ?? error}` });
    return;
  }
  received.set(topic, received.get(topic) + 1);
  emit({ op: "message", topic, logTime: timestamp.toString(), message });
  checkDone();
});

client.on("advertiseServices", (services) => {
  for (const service of services) {
    emit({ op: "advertiseServices", id: service.id, name: service.name, type: service.type });
    if (serviceCall === undefined || serviceCall.sent || service.name !== args.callService) continue;
    try {
      const request = serviceDefinition(service, "request");
      const response = serviceDefinition(service, "response");
      serviceDefs = { response: new MessageReader(response.definitions) };
      const value = forWriter(JSON.parse(args.requestJson), request.definitions, undefined);
      const data = new MessageWriter(request.definitions).writeMessage(value);
      client.sendServiceCallRequest({
        serviceId: service.id, callId: serviceCall.callId, encoding: request.encoding, data,
      });
      serviceCall.sent = true;
      emit({ op: "serviceRequest", service: service.name, callId: serviceCall.callId });
    } catch (error) {
      emit({ op: "error", service: service.name, error: String(error?.message ?? error) });
      serviceCall.done = true;
      checkDone();
    }
  }
});

client.on("serviceCallResponse", (response) => {
  if (serviceCall === undefined || response.callId !== serviceCall.callId) return;
  let decoded;
  try {
    decoded = serviceDefs.response.readMessage(response.data);
  } catch (error) {
    emit({ op: "error", service: args.callService, error: `cannot decode: ${error?.message ?? error}` });
    decoded = undefined;
  }
  emit({
    op: "serviceResponse", service: args.callService, callId: response.callId,
    encoding: response.encoding, response: decoded,
  });
  serviceCall.done = true;
  checkDone();
});

client.on("serviceCallFailure", (failure) => {
  emit(failure);
  if (serviceCall !== undefined && failure.callId === serviceCall.callId) {
    serviceCall.done = true;
    checkDone();
  }
});

client.on("parameterValues", (event) => {
  emit(event);
  if (event.id !== undefined && pendingParameterRequests.delete(event.id)) checkDone();
});

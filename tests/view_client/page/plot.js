// A page that watches `servolab view` the way a Foxglove app does: Foxglove's own
// FoxgloveClient (@foxglove/ws-protocol) over the browser's WebSocket, ROS 2 CDR decoded by
// @foxglove/rosmsg2-serialization from the schema text the server advertises (parsed by
// @foxglove/rosmsg). It draws one joint's position over time on a canvas: white background,
// black axes, the curve in pure blue (#0000ff), 2 px, y autoscaled over what arrived.
//
// Query: url, subprotocol (foxglove.sdk.v1), topic (/joint_states), joint (left_knee),
// count (40). It keeps window.samples = [[t, angle], ...] (t = header stamp in seconds,
// sec + nanosec / 1e9), window.stamps = [[sec, nanosec], ...], window.errors, and sets
// window.done = true after `count` samples, window.ended = "count"; a connection that fails
// or closes first sets window.ended = "close" (and window.done = true).
import { FoxgloveClient } from "@foxglove/ws-protocol";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { parse } from "@foxglove/rosmsg";

const query = new URLSearchParams(window.location.search);
const url = query.get("url");
const subprotocol = query.get("subprotocol") ?? FoxgloveClient.SUPPORTED_SUBPROTOCOL;
const topic = query.get("topic") ?? "/joint_states";
const joint = query.get("joint") ?? "left_knee";
const count = Number.parseInt(query.get("count") ?? "40", 10);

window.samples = [];
window.stamps = [];
window.errors = [];
window.done = false;
window.ended = undefined;

const CURVE = "#0000ff";
const canvas = document.getElementById("plot");
const ctx = canvas.getContext("2d");
const margin = { left: 60, right: 20, top: 30, bottom: 40 };

function draw() {
  const { width, height } = canvas;
  const w = width - margin.left - margin.right;
  const h = height - margin.top - margin.bottom;
  ctx.fillStyle = "#ffffff";
  ctx.fillRect(0, 0, width, height);
  ctx.fillStyle = "#000000";
  ctx.font = "14px sans-serif";
  ctx.fillText(`${topic} ${joint} position (rad) over time (s)`, margin.left, 20);
  // axes
  ctx.strokeStyle = "#000000";
  ctx.lineWidth = 1;
  ctx.beginPath();
  ctx.moveTo(margin.left, margin.top);
  ctx.lineTo(margin.left, margin.top + h);
  ctx.lineTo(margin.left + w, margin.top + h);
  ctx.stroke();
  const samples = window.samples;
  if (samples.length === 0) return;
  const t0 = samples[0][0];
  let t1 = samples[samples.length - 1][0];
  if (t1 <= t0) t1 = t0 + 1;
  let lo = Math.min(...samples.map((s) => s[1]));
  let hi = Math.max(...samples.map((s) => s[1]));
  if (hi - lo < 1e-9) { lo -= 0.5; hi += 0.5; }
  const pad = 0.05 * (hi - lo);
  lo -= pad; hi += pad;
  const x = (t) => margin.left + ((t - t0) / (t1 - t0)) * w;
  const y = (v) => margin.top + (1 - (v - lo) / (hi - lo)) * h;
  ctx.fillStyle = "#000000";
  ctx.fillText(hi.toFixed(2), 5, margin.top + 5);
  ctx.fillText(lo.toFixed(2), 5, margin.top + h);
  ctx.fillText("0", margin.left, margin.top + h + 20);
  ctx.fillText((t1 - t0).toFixed(2), margin.left + w - 30, margin.top + h + 20);
  ctx.strokeStyle = CURVE;
  ctx.lineWidth = 2;
  ctx.beginPath();
  samples.forEach(([t, v], i) => (i === 0 ? ctx.moveTo(x(t), y(v)) : ctx.lineTo(x(t), y(v))));
  ctx.stroke();
}

function end(how) {
  if (window.done) return;
  window.ended = how;
  window.done = true;
  draw();
  client.close();
}

draw();
const client = new FoxgloveClient({ ws: new WebSocket(url, [subprotocol]) });
const readers = new Map(); // subscription id -> MessageReader
let subscribed = false;

client.on("error", (error) => window.errors.push(String(error?.message ?? error)));
client.on("close", () => end("close"));
client.on("advertise", (channels) => {
  for (const channel of channels) {
    if (channel.topic !== topic || subscribed) continue;
    try {
      if (channel.encoding !== "cdr") throw new Error(`encoding ${channel.encoding} is not cdr`);
      const reader = new MessageReader(parse(channel.schema, { ros2: true }));
      readers.set(client.subscribe(channel.id), reader);
      subscribed = true;
    } catch (error) {
      window.errors.push(`${topic}: ${error?.message ?? error}`);
    }
  }
});
client.on("message", ({ subscriptionId, data }) => {
  const reader = readers.get(subscriptionId);
  if (reader === undefined || window.done) return;
  let msg;
  try {
    msg = reader.readMessage(data);
  } catch (error) {
    window.errors.push(`cannot decode: ${error?.message ?? error}`);
    return;
  }
  const index = msg.name.indexOf(joint);
  if (index < 0) {
    window.errors.push(`no joint ${joint} in ${msg.name.join(",")}`);
    return;
  }
  const { sec, nanosec } = msg.header.stamp;
  window.samples.push([sec + nanosec / 1e9, msg.position[index]]);
  window.stamps.push([sec, nanosec]);
  draw();
  if (window.samples.length >= count) end("count");
});

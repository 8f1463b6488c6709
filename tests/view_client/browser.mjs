// A real browser watching `servolab view`: headless Chromium (the build shipped inside the
// @sparticuz/chromium npm package, driven by puppeteer-core) opens page/plot.html, where
// Foxglove's own client library connects over the browser's WebSocket and draws one joint's
// angle over time on a canvas (page/plot.js, bundled by `make view-oracle` into
// build/plot.bundle.js). servolab's tests run it (tests/robots/test_view_browser.py).
//
//   node browser.mjs --url ws://127.0.0.1:PORT [--subprotocol foxglove.sdk.v1]
//       [--topic /joint_states] [--joint left_knee] [--count 40] --screenshot PATH
//       [--timeout 60]
//
// Once the page has `--count` samples (or the server closed the connection) it screenshots
// the page to PATH, prints one JSON object on stdout ({"samples": [[t, angle], ...],
// "stamps": [[sec, nanosec], ...], "ended": "count" | "close", "errors": [...],
// "userAgent": ..., "browser": ...}) and exits 0. At --timeout seconds it does the same with
// "ended": "timeout" and exits 2; any other failure: a message on stderr, exit 1; bad
// arguments: exit 64. Chromium is closed on every path (a signal included).
import { mkdirSync } from "node:fs";
import { dirname, resolve } from "node:path";
import { fileURLToPath, pathToFileURL } from "node:url";

import chromium from "@sparticuz/chromium";
import puppeteer from "puppeteer-core";

const HERE = dirname(fileURLToPath(import.meta.url));
const PAGE = resolve(HERE, "page", "plot.html");
const WIDTH = 800;
const HEIGHT = 400;

function usage(message) {
  process.stderr.write(`browser.mjs: ${message}\n`);
  process.exit(64);
}

function parseArgs(argv) {
  const args = {
    url: undefined, subprotocol: "foxglove.sdk.v1", topic: "/joint_states", joint: "left_knee",
    count: 40, screenshot: undefined, timeout: 60,
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
      case "--topic": args.topic = value(); break;
      case "--joint": args.joint = value(); break;
      case "--count": args.count = Number.parseInt(value(), 10); break;
      case "--screenshot": args.screenshot = resolve(value()); break;
      case "--timeout": args.timeout = Number.parseFloat(value()); break;
      default: usage(`unknown argument ${flag}`);
    }
  }
  if (!args.url) usage("--url is required");
  if (!args.screenshot) usage("--screenshot is required");
  if (!Number.isFinite(args.count) || args.count < 1) usage("--count wants a number >= 1");
  if (!Number.isFinite(args.timeout) || args.timeout <= 0) usage("--timeout wants seconds > 0");
  return args;
}

const args = parseArgs(process.argv.slice(2));
const deadline = Date.now() + args.timeout * 1000;
let browser;

// Chromium must not outlive this script: on a signal kill it outright, then leave.
function killBrowser() {
  const child = browser?.process();
  if (child && child.exitCode === null && child.signalCode === null) child.kill("SIGKILL");
}
for (const signal of ["SIGINT", "SIGTERM", "SIGHUP"]) {
  process.on(signal, () => {
    killBrowser();
    process.exit(128 + ({ SIGINT: 2, SIGTERM: 15, SIGHUP: 1 })[signal]);
  });
}
process.on("exit", killBrowser);

async function main() {
  browser = await puppeteer.launch({
    executablePath: await chromium.executablePath(),
    args: chromium.args,
    headless: true,
    handleSIGINT: false,
    handleSIGTERM: false,
    handleSIGHUP: false,
    defaultViewport: { width: WIDTH, height: HEIGHT },
    timeout: Math.max(1000, deadline - Date.now()),
  });
  try {
    const page = await browser.newPage();
    const pageErrors = [];
    page.on("pageerror", (error) => pageErrors.push(String(error?.message ?? error)));
    const query = new URLSearchParams({
      url: args.url, subprotocol: args.subprotocol, topic: args.topic, joint: args.joint,
      count: String(args.count),
    });
    const address = `${pathToFileURL(PAGE).href}?${query}`;
    await page.goto(address, { waitUntil: "load", timeout: Math.max(1000, deadline - Date.now()) });
    let ended;
    try {
      await page.waitForFunction("window.done === true", {
        polling: 50, timeout: Math.max(1, deadline - Date.now()),
      });
      ended = await page.evaluate("window.ended");
    } catch (error) {
      if (error?.name !== "TimeoutError") throw error;
      ended = "timeout";
    }
    mkdirSync(dirname(args.screenshot), { recursive: true });
    await page.screenshot({ path: args.screenshot });
    const state = await page.evaluate(
      "({ samples: window.samples ?? [], stamps: window.stamps ?? [], errors: window.errors ?? [] })");
    const userAgent = await page.evaluate("navigator.userAgent");
    const result = {
      samples: state.samples, stamps: state.stamps, ended,
      errors: [...state.errors, ...pageErrors], userAgent, browser: await browser.version(),
    };
    process.stdout.write(`${JSON.stringify(result)}\n`);
    return ended === "timeout" ? 2 : 0;
  } finally {
    await browser.close().catch(killBrowser);
  }
}

let code;
try {
  code = await main();
} catch (error) {
  process.stderr.write(`browser.mjs: ${error?.stack ?? error}\n`);
  code = 1;
}
killBrowser();
process.exit(code);

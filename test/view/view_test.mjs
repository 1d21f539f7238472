// The live view from its real clients:
//  1. the Foxglove WebSocket protocol's reference client (@foxglove/ws-protocol
//     over the ws package) subscribes to the scene's image channel and decodes a
//     frame (sensor_msgs/msg/Image in CDR, read with @foxglove/cdr);
//  2. the page in headless Chromium (Debian's, driven by playwright-core) shows
//     frames that keep coming, and a box dragged on the frame reaches the fovea:
//     its state (the page's /fovea/state/json subscription) tracks that box, and
//     the server counts the injected target.
//   node view_test.mjs HOST GRAPH       (HOST: saccade_view_host)
// SACCADE_NPM_DIR names the folder whose node_modules holds the clients
// (scripts/install-test-npm.sh puts them in <build>/npm/view). Every wait is
// bounded; none measures time.
import { spawn } from "node:child_process";
import { createRequire } from "node:module";
import path from "node:path";
import readline from "node:readline";

const [host, graph] = process.argv.slice(2);
const npmDir = process.env.SACCADE_NPM_DIR;
if (!host || !graph || !npmDir) {
  console.error("usage: SACCADE_NPM_DIR=DIR node view_test.mjs HOST GRAPH");
  process.exit(2);
}
let require;
try {
  require = createRequire(path.join(path.resolve(npmDir), "package.json"));
  require.resolve("playwright-core");
} catch {
  console.error(`view_test: no npm test clients in ${npmDir}: run scripts/install-test-npm.sh first`);
  process.exit(1);
}
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const { CdrReader } = require("@foxglove/cdr");
const WebSocket = require("ws");
const { chromium } = require("playwright-core");

const failures = [];
function check(cond, what) {
  console.log(`${cond ? "ok" : "FAILED"}: ${what}`);
  if (!cond) failures.push(what);
}
function within(promise, seconds, what) {
  let timer;
  return Promise.race([
    promise,
    new Promise((_, reject) => { timer = setTimeout(() => reject(new Error(`gave up waiting for ${what}`)), seconds * 1000); }),
  ]).finally(() => clearTimeout(timer));
}

// The graph with its view server.
const child = spawn(host, [graph, "0"], { stdio: ["pipe", "pipe", "inherit"] });
const lines = readline.createInterface({ input: child.stdout });
let counters = null;
const url = await within(new Promise((resolve, reject) => {
  lines.on("line", (line) => {
    if (line.startsWith("view: ")) resolve(line.slice(6));
    if (line.startsWith("counters: ")) counters = JSON.parse(line.slice(10));
  });
  child.on("exit", (code) => reject(new Error(`the host exited (${code}) before listening`)));
}), 60, "the view server");
console.log(`view at ${url}`);
const wsUrl = url.replace("http://", "ws://");

async function foxgloveClient() {
  const client = new FoxgloveClient({ ws: new WebSocket(wsUrl, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
  let info = null;
  client.on("serverInfo", (i) => { info = i; });
  const frame = await within(new Promise((resolve, reject) => {
    client.on("error", reject);
    client.on("advertise", (channels) => {
      const image = channels.find((c) => c.topic === "/scene/image");
      if (!image) return reject(new Error("no /scene/image channel"));
      check(image.schemaName === "sensor_msgs/msg/Image" && image.encoding === "cdr", "the image channel is a ROS 2 Image in CDR");
      const sub = client.subscribe(image.id);
      client.on("message", (m) => { if (m.subscriptionId === sub) resolve(m); });
    });
  }), 60, "a frame through the Foxglove client");
  check(info && info.capabilities.includes("clientPublish"), "serverInfo offers clientPublish");
  const r = new CdrReader(new DataView(frame.data.buffer, frame.data.byteOffset, frame.data.byteLength));
  r.int32(); r.uint32();              // stamp
  r.string();                         // frame_id
  const height = r.uint32(), width = r.uint32();
  const encoding = r.string();
  r.uint8();                          // is_bigendian
  const step = r.uint32();
  const data = r.uint8Array();
  check(width === 320 && height === 240, `the decoded frame is 320x240 (got ${width}x${height} ${encoding})`);
  check(data.length === step * height && step >= width, `its data is step x height bytes (${data.length})`);
  client.close();
}

async function page() {
  // playwright-core starts it headless with a new empty profile of its own.
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
    args: ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
      "--disable-background-networking", "--disable-component-update", "--disable-sync"],
  });
  try {
    const tab = await browser.newPage({ viewport: { width: 1280, height: 900 } });
    tab.on("pageerror", (e) => failures.push(`page error: ${e.message}`));
    await tab.goto(url);
    const frames = () => tab.evaluate(() => window.saccadeView.frames);
    await tab.waitForFunction(() => window.saccadeView.frames >= 3, null, { timeout: 60000 });
    const first = await frames();
    await tab.waitForFunction((n) => window.saccadeView.frames >= n + 5, first, { timeout: 60000 });
    check(true, `frames update on the page (${first} -> ${await frames()})`);
    check(await tab.evaluate(() => window.saccadeView.imageTopic) === "/scene/image/jpeg", "the page shows the scene's frames first");
    await tab.waitForFunction(() => document.querySelectorAll("#node-stats tbody tr").length === 4, null, { timeout: 60000 });
    check(true, "the graph's per-node stats are shown");

    // Drag a box over a quarter of the frame, from 20% to 45% of each side.
    const canvas = await tab.$("#frame");
    const b = await canvas.boundingBox();
    const size = await tab.evaluate(() => [document.getElementById("frame").width, document.getElementById("frame").height]);
    await tab.mouse.move(b.x + 0.2 * b.width, b.y + 0.2 * b.height);
    await tab.mouse.down();
    await tab.mouse.move(b.x + 0.35 * b.width, b.y + 0.3 * b.height, { steps: 5 });
    await tab.mouse.move(b.x + 0.45 * b.width, b.y + 0.45 * b.height, { steps: 5 });
    await tab.mouse.up();
    const want = { x: 0.325 * size[0], y: 0.325 * size[1], w: 0.25 * size[0], h: 0.25 * size[1] };
    check(await tab.evaluate(() => window.saccadeView.targetsSent) === 1, "the drag sent one target");
    // The fovea's state shows a tracked target where the box was.
    await tab.waitForFunction((w) => window.saccadeView.foveaStates.some((s) => s.target_valid &&
      Math.abs(s.target.x + s.target.w / 2 - w.x) < 6 && Math.abs(s.target.y + s.target.h / 2 - w.y) < 6 &&
      Math.abs(s.target.w - w.w) < 8), want, { timeout: 60000 });
    check(true, `the fovea tracks the dragged box (centre ${want.x.toFixed(0)},${want.y.toFixed(0)})`);
    await tab.waitForFunction(() => window.saccadeView.view && window.saccadeView.view.injected === 1, null, { timeout: 60000 });
    check(true, "the server counted one injected target");
    check(await tab.evaluate(() => window.saccadeView.view.malformed) === 0, "no malformed message from the page");
  } finally {
    await browser.close();
  }
}

let status = 0;
try {
  await foxgloveClient();
  await page();
} catch (e) {
  failures.push(e.message);
  console.log(`FAILED: ${e.message}`);
}
child.stdin.end();
await within(new Promise((resolve) => child.on("exit", resolve)), 60, "the host to stop").catch((e) => failures.push(e.message));
check(counters !== null && counters.injected === 1, `the host's final counters: ${JSON.stringify(counters)}`);
if (failures.length) {
  console.log(`view_test: ${failures.length} failed`);
  status = 1;
} else {
  console.log("view_test: all passed");
}
process.exit(status);

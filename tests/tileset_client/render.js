// CesiumJS (npm `cesium`) in headless Chromium via puppeteer-core ($CHROMIUM, which
// tests/test_tileset_client.py sets from tests/conftest.py's chromium(); else /usr/bin/chromium)
// loads OUT/tileset.json from a 127.0.0.1 server, with no network and no Cesium ion, renders one
// view per requested height and prints one JSON line per view: the tileset's statistics once
// every tile of the view is loaded, plus the page's console errors and failed requests.
//
// usage: node render.js OUT LON LAT HEIGHT [HEIGHT ...]   (degrees, metres above the ellipsoid)
// SCREENSHOTS=folder also saves view_<height>m.png per view.
// PICK='[[lon, lat, height], ...]' also picks each point's screen position in every view (scene.pick)
// and reports what it found: a proxy's feature (its property table's values) or a building level's
// content (its content metadata or group metadata values), with the content's uri.
// POSES=file.json (then LON LAT HEIGHT are not given): {"width", "height", "target", "tileset"
// (a file in OUT, default tileset.json), "views":
// [{"position": [x, y, z], "direction": [...], "up": [...]}]} (ECEF metres, unit vectors), each
// view on a freshly loaded tileset (so memory is what that view needs); each line adds the
// contents selected whose URI starts with "target" (or, when none, the selected content whose
// tile holds the target's chain: a proxy), totalMemoryUsageInBytes and the texture bytes.
"use strict";
const http = require("http");
const fs = require("fs");
const path = require("path");
const puppeteer = require("puppeteer-core");

const [out, lon, lat, ...heights] = process.argv.slice(2);
const POSES = process.env.POSES ? JSON.parse(fs.readFileSync(process.env.POSES, "utf8")) : null;
const CESIUM = path.join(__dirname, "node_modules", "cesium", "Build", "Cesium");
const TYPES = { ".js": "text/javascript", ".json": "application/json", ".glb": "model/gltf-binary",
  ".css": "text/css", ".html": "text/html", ".png": "image/png", ".jpg": "image/jpeg",
  ".wasm": "application/wasm", ".xml": "text/xml", ".svg": "image/svg+xml" };

const PAGE = `<!doctype html><html><head><meta charset="utf-8">
<script src="/cesium/Cesium.js"></script>
<link rel="stylesheet" href="/cesium/Widgets/widgets.css">
<style>html,body,#view{margin:0;width:100%;height:100%;overflow:hidden}</style></head>
<body><div id="view"></div><script>
window.CESIUM_BASE_URL = "/cesium/";
Cesium.Ion.defaultAccessToken = undefined;
const widget = new Cesium.CesiumWidget("view", { baseLayer: false, skyBox: false,
  skyAtmosphere: false, requestRenderMode: false, shadows: false });
widget.scene.globe.baseColor = Cesium.Color.DARKGREY;
widget.scene.fog.enabled = false; // fog culls tiles a few km away: every view sees the tileset
window.ready = Cesium.Cesium3DTileset.fromUrl("/out/tileset.json").then((tileset) => {
  widget.scene.primitives.add(tileset); window.tileset = tileset; return true; });
window.view = async (lon, lat, height) => {
  const scene = widget.scene, tileset = window.tileset;
  // Look north, 60 degrees down, at the point: the camera stands south of it.
  const pitch = Cesium.Math.toRadians(-60);
  const back = height / Math.tan(-pitch) / 111320;
  scene.camera.setView({ destination: Cesium.Cartesian3.fromDegrees(lon, lat - back, height),
    orientation: { heading: 0, pitch, roll: 0 } });
  for (let frame = 0, quiet = 0; frame < 600 && quiet < 5; frame++) {
    widget.render();
    await new Promise((r) => setTimeout(r, 20));
    quiet = tileset.tilesLoaded ? quiet + 1 : 0;
  }
  widget.render();
  const s = tileset.statistics;
  const picks = (window.PICK || []).map(([plon, plat, ph]) => {
    const at = Cesium.SceneTransforms.worldToWindowCoordinates(scene,
      Cesium.Cartesian3.fromDegrees(plon, plat, ph));
    const found = at && scene.pick(at);
    if (!found) return { at: at && [at.x, at.y], kind: null };
    const values = (entity) => Object.fromEntries(entity.getPropertyIds().map((id) => {
      const value = entity.getProperty(id);
      return [id, typeof value === "bigint" ? Number(value) : value];
    }));
    const uri = found.content && found.content.url;
    if (found instanceof Cesium.Cesium3DTileFeature) {
      return { at: [at.x, at.y], kind: "feature", uri, featureId: found.featureId, values: values(found) };
    }
    // A building level's values: its content metadata (a tile's own tileset), or its group.
    const group = found.content && found.content.group;
    const entity = (found.content && found.content.metadata) || (group && group.metadata);
    return { at: [at.x, at.y], kind: "content", uri, values: entity ? values(entity) : null };
  });
  return { height, picks, selected: s.selected, commands: s.numberOfCommands,
    triangles: s.numberOfTrianglesSelected, visited: s.visited,
    contentReady: s.numberOfTilesWithContentReady, loaded: tileset.tilesLoaded,
    geometryBytes: s.geometryByteLength, textureBytes: s.texturesByteLength };
};
window.pose = async (view, target, name) => {
  const scene = widget.scene;
  scene.primitives.removeAll();
  const tileset = await Cesium.Cesium3DTileset.fromUrl("/out/" + name);
  scene.primitives.add(tileset);
  const visible = new Set();
  tileset.tileVisible.addEventListener((tile) => visible.add(tile));
  scene.camera.setView({ destination: Cesium.Cartesian3.fromArray(view.position),
    orientation: { direction: Cesium.Cartesian3.fromArray(view.direction),
      up: Cesium.Cartesian3.fromArray(view.up) } });
  for (let frame = 0, quiet = 0; frame < 1500 && quiet < 5; frame++) {
    widget.render();
    await new Promise((r) => setTimeout(r, 20));
    quiet = tileset.tilesLoaded ? quiet + 1 : 0;
  }
  visible.clear();
  widget.render();
  const uri = (tile) => tile._contentResource
    ? decodeURIComponent(new URL(tile._contentResource.url).pathname).slice("/out/".length) : "";
  let selected = [...visible].map(uri).filter((u) => u.startsWith(target));
  if (!selected.length) {  // a coarser content covers the target: the selected tile above it
    // The target's chain, or the tile referencing its tile's own tileset when that is not
    // loaded yet (an external tileset is fetched only when its tile is refined).
    const own = target.split("/")[0] + "/tileset.json";
    const stack = [tileset.root];
    let top = null;
    while (stack.length && !top) {
      const tile = stack.pop();
      if (uri(tile).startsWith(target) || uri(tile) === own) top = tile;
      else stack.push(...tile.children);
    }
    for (let tile = top; tile && !selected.length; tile = tile.parent) {
      if (visible.has(tile) && uri(tile)) selected = [uri(tile)];
    }
  }
  const s = tileset.statistics;
  return { selected: s.selected, target: selected.sort(), loaded: tileset.tilesLoaded,
    memory: tileset.totalMemoryUsageInBytes, textureBytes: s.texturesByteLength };
};
</script></body></html>`;

function serve(request, response) {
  const url = decodeURIComponent(new URL(request.url, "http://127.0.0.1").pathname);
  let file = null;
  if (url === "/favicon.ico") {
    response.writeHead(204);
    return response.end();
  }
  if (url === "/" || url === "/index.html") {
    response.writeHead(200, { "Content-Type": "text/html" });
    return response.end(PAGE);
  }
  if (url.startsWith("/cesium/")) file = path.join(CESIUM, url.slice(8));
  if (url.startsWith("/out/")) file = path.join(out, url.slice(5));
  fs.readFile(file || "/nonexistent", (error, data) => {
    if (error) { response.writeHead(404); return response.end(); }
    response.writeHead(200, { "Content-Type": TYPES[path.extname(file)] || "application/octet-stream" });
    response.end(data);
  });
}

(async () => {
  const server = http.createServer(serve).listen(0, "127.0.0.1");
  await new Promise((r) => server.once("listening", r));
  const port = server.address().port;
  const browser = await puppeteer.launch({
    executablePath: process.env.CHROMIUM || "/usr/bin/chromium", headless: true,
    args: ["--no-sandbox", "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
      "--disable-background-networking", "--disable-component-update", "--no-first-run",
      `--window-size=${POSES ? POSES.width : 1280},${POSES ? POSES.height : 720}`],
    defaultViewport: { width: POSES ? POSES.width : 1280, height: POSES ? POSES.height : 720 },
    protocolTimeout: 1800000, // a view of a loaded machine may render for minutes
  });
  const errors = [];
  try {
    const page = await browser.newPage();
    page.on("console", (m) => { if (m.type() === "error") errors.push(m.text()); });
    page.on("pageerror", (e) => errors.push(String(e)));
    page.on("requestfailed", (r) => errors.push(`request failed: ${r.url()}`));
    page.on("response", (r) => { if (r.status() >= 400) errors.push(`HTTP ${r.status()}: ${r.url()}`); });
    await page.setRequestInterception(true);
    page.on("request", (r) => (r.url().startsWith(`http://127.0.0.1:${port}/`) ? r.continue() : r.abort()));
    await page.goto(`http://127.0.0.1:${port}/index.html`, { waitUntil: "load" });
    await page.evaluate(() => window.ready);
    await page.evaluate((points) => { window.PICK = points; }, JSON.parse(process.env.PICK || "[]"));
    for (const view of POSES ? POSES.views : []) {
      const stats = await page.evaluate((a, b, c) => window.pose(a, b, c), view, POSES.target,
        POSES.tileset || "tileset.json");
      console.log(JSON.stringify({ ...stats, errors: errors.splice(0) }));
    }
    for (const height of POSES ? [] : heights) {
      const stats = await page.evaluate((a, b, c) => window.view(a, b, c), +lon, +lat, +height);
      if (process.env.SCREENSHOTS) {
        await page.screenshot({ path: path.join(process.env.SCREENSHOTS, `view_${height}m.png`) });
      }
      console.log(JSON.stringify({ ...stats, errors: errors.splice(0) }));
    }
  } catch (error) {
    console.log(JSON.stringify({ fatal: String(error), errors }));
  } finally {
    await browser.close();
    server.close();
  }
})();

// SPDX-License-Identifier: MIT
// Screenshots of the face viewer (tools/viewer) in headless Chromium, driven by playwright-core.
// Serves ROOT (the page, node_modules, the .glb) on 127.0.0.1 with Node's own HTTP server, opens
// index.html?QUERY at W x H for each pair and saves the canvas as OUT.png. Exit 0, or 1 on any error
// (the page's own error included).
// usage: node viewer_shot.cjs CHROMIUM ROOT W H OUT.png QUERY [W H OUT.png QUERY ...]
'use strict';
const http = require('http');
const fs = require('fs');
const path = require('path');
const { chromium } = require('playwright-core');

const TYPES = { '.html': 'text/html', '.js': 'text/javascript', '.wasm': 'application/wasm',
  '.glb': 'model/gltf-binary', '.hdr': 'application/octet-stream', '.json': 'application/json' };

function serve(root) {
  const server = http.createServer((req, res) => {
    const rel = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    const file = path.join(root, path.normalize(rel));
    if (!file.startsWith(root)) { res.writeHead(403); res.end(); return; }
    fs.readFile(file, (err, data) => {
      if (err) { res.writeHead(404); res.end(); return; }
      res.writeHead(200, { 'Content-Type': TYPES[path.extname(file)] || 'application/octet-stream' });
      res.end(data);
    });
  });
  return new Promise((ok) => server.listen(0, '127.0.0.1', () => ok(server)));
}

async function main() {
  const [exe, root, ...jobs] = process.argv.slice(2);
  if (!exe || !root || jobs.length === 0 || jobs.length % 4) throw new Error('usage: see the file header');
  const server = await serve(path.resolve(root));
  const base = `http://127.0.0.1:${server.address().port}/index.html?`;
  const browser = await chromium.launch({ executablePath: exe, headless: true,
    args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
      '--disable-background-networking', '--disable-component-update', '--no-first-run'] });
  try {
    for (let i = 0; i < jobs.length; i += 4) {
      const [w, h, out, query] = [Number(jobs[i]), Number(jobs[i + 1]), jobs[i + 2], jobs[i + 3]];
      const page = await browser.newPage({ viewport: { width: w, height: h }, deviceScaleFactor: 1 });
      const logs = [];
      page.on('console', (m) => logs.push(m.text()));
      page.on('pageerror', (e) => logs.push(String(e)));
      await page.goto(base + query);
      await page.waitForFunction(() => window.sunprobeViewer && window.sunprobeViewer.status !== 'loading',
        null, { timeout: 90000 });
      const st = await page.evaluate(() => window.sunprobeViewer);
      if (st.status !== 'ready') throw new Error(`viewer: ${st.message}\n${logs.join('\n')}`);
      await page.locator('canvas').screenshot({ path: out });
      await page.close();
    }
  } finally {
    await browser.close();
    server.close();
  }
}

main().catch((e) => { console.error(String(e && e.stack ? e.stack : e)); process.exit(1); });

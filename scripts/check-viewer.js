// The browser half of scripts/check-viewer.sh (see there): drives Debian's Chromium through
// playwright-core. Usage: node scripts/check-viewer.js VIEWER.html FINAL_CELLS WORK_DIR
'use strict';
const { chromium } = require('playwright-core');
const [file, finalCells, work] = process.argv.slice(2);
const errors = [];
let failed = false;
const pass = (m) => console.log(`PASS  ${m}`);
const bad = (m) => { console.log(`FAIL  ${m}`); failed = true; };

// Non-blank: the share of pixels that differ from the background colour, and how many
// colours (quantized to 4 bits per channel) the picture has.
async function pictureStats(page) {
  return page.evaluate(() => {
    const src = document.querySelector('#view canvas');
    const c = document.createElement('canvas');
    c.width = src.width; c.height = src.height;
    const g = c.getContext('2d');
    g.drawImage(src, 0, 0);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    const bg = [d[0], d[1], d[2]];
    let differ = 0; const colours = new Set();
    for (let i = 0; i < d.length; i += 4) {
      if (Math.abs(d[i] - bg[0]) + Math.abs(d[i + 1] - bg[1]) + Math.abs(d[i + 2] - bg[2]) > 24) differ++;
      colours.add((d[i] >> 4) << 8 | (d[i + 1] >> 4) << 4 | (d[i + 2] >> 4));
    }
    return { share: differ / (d.length / 4), colours: colours.size };
  });
}

(async () => {
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    args: ['--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--no-sandbox'],
  });
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  page.on('console', (m) => { if (m.type() === 'error') errors.push(`console: ${m.text()}`); });
  page.on('pageerror', (e) => errors.push(`page error: ${e.message}`));
  page.on('requestfailed', (r) => errors.push(`request failed: ${r.url()}`));
  await page.goto('file://' + file);
  try {
    await page.waitForFunction(() => window.portalfindViewer && window.portalfindViewer.ready, null, { timeout: 120000 });
  } catch (e) {
    const status = await page.textContent('#status').catch(() => '?');
    bad(`the page did not become ready: ${status}; ${errors.join('; ')}`);
    await browser.close();
    process.exit(1);
  }
  const v = await page.evaluate(() => {
    const s = window.portalfindViewer;
    return { step: s.step, cells: s.cells, initial: s.initialCells, steps: s.steps, stop: s.stop, shown: s.shown() };
  });
  console.log(`page: ${v.initial} initial cells, ${v.steps} collapses, stop after ${v.stop}; ` +
    `at load step ${v.step}, ${v.cells} cells, ${v.shown.cellTriangles} cell and ${v.shown.portalTriangles} portal triangles drawn`);
  if (v.step === v.stop && String(v.cells) === finalCells) pass(`loads at the run's stop: ${v.cells} cells, as the run printed`);
  else bad(`at load: step ${v.step} (stop ${v.stop}), ${v.cells} cells; the run printed ${finalCells}`);
  await page.screenshot({ path: `${work}/viewer_stop.png` });
  const atStop = await pictureStats(page);
  if (atStop.share > 0.05 && atStop.colours >= 8) pass(`picture at the stop is not blank: ${(100 * atStop.share).toFixed(1)}% of pixels drawn, ${atStop.colours} colours`);
  else bad(`picture at the stop looks blank: ${(100 * atStop.share).toFixed(1)}% of pixels drawn, ${atStop.colours} colours`);

  // Step the slider: real key presses on the focused slider, then set its value.
  const slider = page.locator('#step');
  await slider.focus();
  const expect = async (what, k) => {
    const s = await page.evaluate(() => ({ step: window.portalfindViewer.step, cells: window.portalfindViewer.cells }));
    const want = await page.evaluate((k) => window.portalfindViewer.remaining(k), k);
    const label = await page.textContent('#stepinfo');
    if (s.step === k && s.cells === want && label.includes(`step ${k} of`)) pass(`${what}: step ${k}, ${s.cells} cells`);
    else bad(`${what}: expected step ${k} with ${want} cells, page has step ${s.step} with ${s.cells} cells ("${label}")`);
  };
  await page.keyboard.press('Home');
  await expect('slider Home key', 0);
  await page.screenshot({ path: `${work}/viewer_step0.png` });
  const atZero = await pictureStats(page);
  if (atZero.share > 0.05) pass(`picture at step 0 is not blank: ${(100 * atZero.share).toFixed(1)}% of pixels drawn, ${atZero.colours} colours`);
  else bad(`picture at step 0 looks blank: ${(100 * atZero.share).toFixed(1)}%`);
  for (let i = 1; i <= 3 && i <= v.steps; i++) {
    await page.keyboard.press('ArrowRight');
    await expect(`slider ArrowRight x${i}`, i);
  }
  await page.keyboard.press('End');
  await expect('slider End key', v.steps);
  const mid = Math.floor(v.steps / 2);
  await slider.fill(String(mid));
  await expect('slider set to the middle', mid);
  await page.click('#stop');
  await expect('"the run\'s stop" button', v.stop);

  // Click the middle of the picture.
  const box = await page.locator('#view canvas').boundingBox();
  let info = '';
  for (const [fx, fy] of [[0.5, 0.5], [0.55, 0.45], [0.45, 0.55], [0.6, 0.6], [0.4, 0.4]]) {
    await page.mouse.click(box.x + box.width * fx, box.y + box.height * fy);
    info = (await page.innerText('#info')).replace(/\n/g, '; ');
    if (/^(cell|portal) /.test(info)) break;
  }
  if (/^cell \d+: .*volume/.test(info) || /^portal \d+.\d+: .*area/.test(info)) pass(`click shows: ${info}`);
  else bad(`click on the picture selected nothing: "${info}"`);

  if (errors.length === 0) pass('no console errors, no page errors, no failed requests');
  else bad(`errors: ${errors.join(' | ')}`);
  await browser.close();
  process.exit(failed ? 1 : 0);
})().catch((e) => { console.log(`FAIL  ${e.stack || e}`); process.exit(1); });

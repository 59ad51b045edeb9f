// lrf viewer: a camera the user moves (orbit, pan, zoom, fly), frames rendered by the server for it.
// The page keeps at most one frame request in flight: while the camera moves it asks for small frames
// and, once the camera has been still for STILL_MS, for one at full resolution; a pose that changed
// while a request was out is sent when it returns, so frames never queue up behind the user.
// Cameras use lrf's convention: world-to-camera rotation R (rows: right, down, forward), centre `eye`.
'use strict';
(() => {
  const STILL_MS = 250;        // still this long: ask for full resolution
  const LOW_SCALE = 0.5;       // frames while moving: this fraction of the full size
  const ORBIT_RAD_PER_PX = 0.005;
  const LOOK_RAD_PER_S = 1.0;
  const $ = (id) => document.getElementById(id);

  // ---- 3-vectors and row-major 3x3 matrices ----
  const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const mul = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const norm = (a) => Math.sqrt(dot(a, a));
  const unit = (a) => mul(a, 1 / norm(a));
  const row = (M, i) => [M[3 * i], M[3 * i + 1], M[3 * i + 2]];
  const matVec = (M, v) => [dot(row(M, 0), v), dot(row(M, 1), v), dot(row(M, 2), v)];
  const transpose = (M) => [M[0], M[3], M[6], M[1], M[4], M[7], M[2], M[5], M[8]];
  function matMul(A, B) {
    const C = new Array(9).fill(0);
    for (let i = 0; i < 3; ++i)
      for (let j = 0; j < 3; ++j)
        for (let k = 0; k < 3; ++k) C[3 * i + j] += A[3 * i + k] * B[3 * k + j];
    return C;
  }
  // Rotation by `angle` about the unit vector `u` (Rodrigues).
  function rotation(u, angle) {
    const c = Math.cos(angle), s = Math.sin(angle), t = 1 - c;
    const [x, y, z] = u;
    return [t * x * x + c, t * x * y - s * z, t * x * z + s * y,
            t * x * y + s * z, t * y * y + c, t * y * z - s * x,
            t * x * z - s * y, t * y * z + s * x, t * z * z + c];
  }
  // Keeps R a rotation despite accumulated rounding (Gram-Schmidt on its rows).
  function orthonormalize(R) {
    const z = unit(row(R, 2));
    const x = unit(sub(row(R, 0), mul(z, dot(row(R, 0), z))));
    const y = cross(z, x);
    return [...x, ...y, ...z];
  }

  // ---- state ----
  let scene = null;
  const cam = { R: [1, 0, 0, 0, 1, 0, 0, 0, 1], eye: [0, 0, 0], focus: 1, intr: null, view: 0 };
  const clientId = Array.from(crypto.getRandomValues(new Uint8Array(8)), (b) => b.toString(16).padStart(2, '0')).join('');
  let seq = 0, poseVersion = 0, lastMove = -1e9;
  let inflight = false, requestedVersion = -1, requestedFull = false;
  const keys = new Set();
  const shownTimes = [];
  // Read by tests and handy in the console.
  const stats = window.lrfViewer = {
    ready: false, framesShown: 0, lowFramesShown: 0, fullFramesShown: 0, lastFull: false, lastSeq: -1,
    lastSize: [0, 0], checksum: 0, errors: 0, lastError: '', fps: 0, poseVersion: 0, shownVersion: -1,
  };

  const forward = () => row(cam.R, 2);
  const right = () => row(cam.R, 0);
  const down = () => row(cam.R, 1);
  const target = () => add(cam.eye, mul(forward(), cam.focus));
  function moved() {
    stats.poseVersion = ++poseVersion;
    lastMove = performance.now();
    drawOverlay();
  }

  // ---- camera controls ----
  function orbit(dx, dy) {
    const t = target(), up = scene.up;
    const yaw = rotation(up, -dx * ORBIT_RAD_PER_PX);
    let Q = yaw;
    const pitch = rotation(right(), -dy * ORBIT_RAD_PER_PX);
    const pitched = matVec(matMul(yaw, pitch), forward());
    if (Math.abs(dot(pitched, up)) < Math.cos(5 * Math.PI / 180)) Q = matMul(yaw, pitch);  // not over the pole
    cam.eye = add(t, matVec(Q, sub(cam.eye, t)));
    cam.R = orthonormalize(matMul(cam.R, transpose(Q)));
    moved();
  }
  function look(yawAngle, pitchAngle) {
    const Q = matMul(rotation(scene.up, yawAngle), rotation(right(), pitchAngle));
    cam.R = orthonormalize(matMul(cam.R, transpose(Q)));
    moved();
  }
  function pan(dx, dy) {
    const perPixel = cam.focus / cam.intr.fx;
    cam.eye = add(cam.eye, add(mul(right(), -dx * perPixel), mul(down(), -dy * perPixel)));
    moved();
  }
  function zoom(amount) {
    const t = target();
    cam.focus = Math.min(Math.max(cam.focus * Math.exp(amount), 1e-3 * scene.radius), 20 * scene.radius);
    cam.eye = sub(t, mul(forward(), cam.focus));
    moved();
  }
  function fly(dt) {
    const speed = scene.radius * 0.3 * (keys.has('shift') ? 4 : 1) * dt;
    let step = [0, 0, 0];
    if (keys.has('w')) step = add(step, forward());
    if (keys.has('s')) step = sub(step, forward());
    if (keys.has('d')) step = add(step, right());
    if (keys.has('a')) step = sub(step, right());
    if (keys.has('e')) step = sub(step, down());
    if (keys.has('q')) step = add(step, down());
    if (norm(step) > 0) {
      cam.eye = add(cam.eye, mul(unit(step), speed));
      moved();
    }
    const yaw = (keys.has('arrowleft') ? 1 : 0) - (keys.has('arrowright') ? 1 : 0);
    const pitch = (keys.has('arrowup') ? 1 : 0) - (keys.has('arrowdown') ? 1 : 0);
    if (yaw || pitch) look(yaw * LOOK_RAD_PER_S * dt, pitch * LOOK_RAD_PER_S * dt);
  }
  function goToView(index) {
    const v = scene.views[index];
    cam.view = index;
    cam.R = v.R.slice();
    cam.eye = mul(matVec(transpose(v.R), v.t), -1);
    cam.intr = { width: v.width, height: v.height, fx: v.fx, fy: v.fy, cx: v.cx, cy: v.cy };
    const depth = dot(forward(), sub(scene.target, cam.eye));
    cam.focus = depth > 0.05 * scene.radius ? depth : 0.5 * scene.radius;
    const frame = $('frame'), overlay = $('overlay');
    frame.width = overlay.width = v.width;
    frame.height = overlay.height = v.height;
    fitCanvas();
    moved();
  }

  // ---- frames ----
  function frameSize(full) {
    const m = scene.size_multiple, w = cam.intr.width, h = cam.intr.height;
    let s = full ? 1 : LOW_SCALE;
    s = Math.min(s, scene.max_side / Math.max(w, h));
    const fit = (n) => Math.max(m, Math.round((n * s) / m) * m);
    return [fit(w), fit(h)];
  }
  function frameUrl(full) {
    const [w, h] = frameSize(full);
    const sx = w / cam.intr.width, sy = h / cam.intr.height;
    const t = mul(matVec(cam.R, cam.eye), -1);
    const q = new URLSearchParams({
      client: clientId, seq: String(++seq), w: String(w), h: String(h),
      fx: String(cam.intr.fx * sx), fy: String(cam.intr.fy * sy), cx: String(cam.intr.cx * sx), cy: String(cam.intr.cy * sy),
      r: cam.R.join(','), t: t.join(','),
    });
    return [`/api/frame?${q}`, seq, w, h];
  }
  async function requestFrame(full) {
    inflight = true;
    requestedVersion = poseVersion;
    requestedFull = full;
    const [url, mySeq, w, h] = frameUrl(full);
    try {
      const res = await fetch(url, { cache: 'no-store' });
      if (res.status === 204) return;  // superseded by a newer request of this page
      if (!res.ok) {
        const body = await res.json().catch(() => ({ error: res.statusText }));
        throw new Error(`${res.status}: ${body.error}`);
      }
      const bitmap = await createImageBitmap(await res.blob());
      if (mySeq > stats.lastSeq) show(bitmap, mySeq, full, [w, h], res.headers);
      bitmap.close();
    } catch (err) {
      stats.errors++;
      stats.lastError = String(err.message || err);
      $('status').textContent = stats.lastError;
      $('status').className = 'stat error';
    } finally {
      inflight = false;
    }
  }
  function show(bitmap, mySeq, full, size, headers) {
    const canvas = $('frame'), ctx = canvas.getContext('2d');
    ctx.imageSmoothingEnabled = true;
    ctx.drawImage(bitmap, 0, 0, canvas.width, canvas.height);
    stats.checksum = checksum(bitmap);
    stats.lastSeq = mySeq;
    stats.lastFull = full;
    stats.lastSize = size;
    stats.shownVersion = requestedVersion;
    stats.framesShown++;
    if (full) stats.fullFramesShown++; else stats.lowFramesShown++;
    const now = performance.now();
    shownTimes.push(now);
    while (shownTimes.length && now - shownTimes[0] > 1000) shownTimes.shift();
    stats.fps = shownTimes.length;
    $('fps').textContent = `FPS ${stats.fps}`;
    const ms = (name) => headers.get(name) || '?';
    $('timing').textContent = `${size[0]}×${size[1]} ${full ? 'full' : 'low'} · render ${ms('X-Lrf-Render-Ms')} ms` +
        (scene.space !== 'rgb' ? ` · decode ${ms('X-Lrf-Decode-Ms')} ms` : '');
    $('status').textContent = '';
    $('status').className = 'stat';
  }
  // A small fingerprint of a frame's pixels, so that a test can tell frames apart.
  function checksum(bitmap) {
    const c = document.createElement('canvas');
    c.width = 16;
    c.height = 12;
    const ctx = c.getContext('2d');
    ctx.drawImage(bitmap, 0, 0, 16, 12);
    const px = ctx.getImageData(0, 0, 16, 12).data;
    let sum = 0;
    for (let i = 0; i < px.length; ++i) sum = (sum * 31 + px[i]) % 1000000007;
    return sum;
  }

  // ---- training cameras, drawn over the frame in the current camera ----
  function project(p) {
    const c = matVec(cam.R, sub(p, cam.eye));
    if (c[2] <= 1e-6 * scene.radius) return null;
    return [cam.intr.fx * c[0] / c[2] + cam.intr.cx, cam.intr.fy * c[1] / c[2] + cam.intr.cy];
  }
  function drawOverlay() {
    const canvas = $('overlay'), ctx = canvas.getContext('2d');
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    if (!scene || !$('show-cameras').checked) return;
    const depth = scene.frustum_depth;
    ctx.lineWidth = Math.max(1, canvas.width / 400);
    scene.views.forEach((v, i) => {
      if (i === cam.view) return;
      const Rt = transpose(v.R), centre = mul(matVec(Rt, v.t), -1);
      const corners = [[0, 0], [v.width, 0], [v.width, v.height], [0, v.height]].map(([u, w]) =>
        add(centre, matVec(Rt, mul([(u - v.cx) / v.fx, (w - v.cy) / v.fy, 1], depth))));
      const c = project(centre), k = corners.map(project);
      ctx.strokeStyle = v.split === 'test' ? '#4cf' : v.split === 'train' ? '#fa3' : '#888';
      ctx.beginPath();
      for (let j = 0; j < 4; ++j) {
        const a = k[j], b = k[(j + 1) % 4];
        if (c && a) { ctx.moveTo(c[0], c[1]); ctx.lineTo(a[0], a[1]); }
        if (a && b) { ctx.moveTo(a[0], a[1]); ctx.lineTo(b[0], b[1]); }
      }
      ctx.stroke();
    });
  }

  // ---- layout and input ----
  function fitCanvas() {
    if (!cam.intr) return;
    const stage = $('stage');
    const s = Math.min(stage.clientWidth / cam.intr.width, stage.clientHeight / cam.intr.height);
    for (const id of ['frame', 'overlay']) {
      $(id).style.width = `${Math.floor(cam.intr.width * s)}px`;
      $(id).style.height = `${Math.floor(cam.intr.height * s)}px`;
    }
  }
  function installInput() {
    const overlay = $('overlay');
    let drag = null;
    overlay.addEventListener('contextmenu', (e) => e.preventDefault());
    overlay.addEventListener('pointerdown', (e) => {
      overlay.focus();
      overlay.setPointerCapture(e.pointerId);
      drag = { x: e.clientX, y: e.clientY, pan: e.button === 2 || e.shiftKey };
    });
    overlay.addEventListener('pointermove', (e) => {
      if (!drag) return;
      // Drags are measured in frame pixels, whatever the canvas's size on screen.
      const scale = cam.intr.width / overlay.clientWidth;
      const dx = (e.clientX - drag.x) * scale, dy = (e.clientY - drag.y) * scale;
      drag.x = e.clientX;
      drag.y = e.clientY;
      if (drag.pan) pan(dx, dy); else orbit(dx, dy);
    });
    const end = () => { drag = null; };
    overlay.addEventListener('pointerup', end);
    overlay.addEventListener('pointercancel', end);
    overlay.addEventListener('wheel', (e) => {
      e.preventDefault();
      zoom(Math.sign(e.deltaY) * Math.min(Math.abs(e.deltaY), 200) * 0.002);
    }, { passive: false });
    window.addEventListener('keydown', (e) => {
      if (e.target instanceof HTMLSelectElement) return;
      keys.add(e.key.toLowerCase());
      if (e.shiftKey) keys.add('shift');
      if (e.key.startsWith('Arrow')) e.preventDefault();
    });
    window.addEventListener('keyup', (e) => {
      keys.delete(e.key.toLowerCase());
      if (!e.shiftKey) keys.delete('shift');
    });
    window.addEventListener('blur', () => keys.clear());
    window.addEventListener('resize', fitCanvas);
    $('views').addEventListener('change', (e) => goToView(Number(e.target.value)));
    $('reset').addEventListener('click', () => goToView(cam.view));
    $('show-cameras').addEventListener('change', drawOverlay);
  }
  function fillViews() {
    const select = $('views');
    for (const split of ['test', 'train', 'unused']) {
      const group = document.createElement('optgroup');
      group.label = `${split} views`;
      scene.views.forEach((v, i) => {
        if (v.split !== split) return;
        const option = document.createElement('option');
        option.value = String(i);
        option.textContent = v.name;
        group.appendChild(option);
      });
      if (group.children.length) select.appendChild(group);
    }
  }

  // ---- the loop ----
  let lastTick = performance.now();
  function tick() {
    const now = performance.now();
    const dt = Math.min((now - lastTick) / 1000, 0.1);
    lastTick = now;
    if (keys.size) fly(dt);
    if (!inflight && document.visibilityState !== 'hidden') {
      const still = now - lastMove >= STILL_MS;
      if (requestedVersion !== poseVersion) requestFrame(still);
      else if (still && !requestedFull) requestFrame(true);
    }
    setTimeout(tick, 15);
  }

  async function main() {
    const res = await fetch('/api/scene', { cache: 'no-store' });
    if (!res.ok) throw new Error(`cannot load the scene: ${res.status}`);
    scene = await res.json();
    // Frusta drawn a quarter of the cameras' spread deep (a tenth of the scene for a single position).
    const centres = scene.views.map((v) => mul(matVec(transpose(v.R), v.t), -1));
    const mean = mul(centres.reduce(add, [0, 0, 0]), 1 / centres.length);
    const spread = Math.max(...centres.map((c) => norm(sub(c, mean))));
    scene.frustum_depth = spread > 0 ? 0.25 * spread : 0.1 * scene.radius;
    $('description').textContent = scene.description;
    fillViews();
    installInput();
    const first = scene.views.findIndex((v) => v.split === 'test');
    const index = first >= 0 ? first : 0;
    $('views').value = String(index);
    goToView(index);
    lastMove = -1e9;  // the first frame is already at full resolution
    stats.ready = true;
    tick();
  }
  main().catch((err) => {
    stats.errors++;
    stats.lastError = String(err.message || err);
    $('status').textContent = stats.lastError;
    $('status').className = 'stat error';
  });
})();

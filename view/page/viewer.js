// isoforge view's page: shows the model the server builds, reloads it on every change the server
// announces (server-sent events on /events), and keeps the camera where the user left it.
// window.isoforgeView exposes what is shown, for tests and for the curious.
(function () {
  'use strict';
  const view = document.getElementById('view');
  const renderer = new THREE.WebGLRenderer({ antialias: true, alpha: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio);
  renderer.setClearColor(0x000000, 0);
  renderer.gammaOutput = true;  // three r111: the colours written to the screen are sRGB
  renderer.gammaFactor = 2.2;
  view.appendChild(renderer.domElement);

  const scene = new THREE.Scene();
  const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 1000);
  camera.up.set(0, 0, 1);  // isoforge's scenes are z-up, as OpenSCAD's
  camera.position.set(0, -5, 3);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x444444, 0.45));
  const headlight = new THREE.DirectionalLight(0xffffff, 0.6);
  headlight.position.set(-1, 1, 2);  // above-left of the eye, moving with it
  camera.add(headlight);
  scene.add(camera);

  const controls = new THREE.OrbitControls(camera, renderer.domElement);
  controls.addEventListener('change', render);

  const state = {
    server: null,         // the last state the server sent
    shownModel: 0,        // the id of the model on screen (0: none)
    shownStage: '',
    loading: 0,           // the id being loaded
    framed: false,        // the first model sets the camera; later ones keep it
    frames: 0,
    camera() {
      return { position: camera.position.toArray(), target: controls.target.toArray(), up: camera.up.toArray(),
               fov: camera.fov };
    },
  };
  window.isoforgeView = state;
  let model = null, bounds = null;

  function render() {
    renderer.render(scene, camera);
    state.frames++;
  }

  function resize() {
    const w = window.innerWidth, h = window.innerHeight;
    renderer.setSize(w, h);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
    render();
  }
  window.addEventListener('resize', resize);

  function fitNearFar() {
    if (!bounds) return;
    const size = bounds.getSize(new THREE.Vector3()).length() || 1;
    const dist = camera.position.distanceTo(bounds.getCenter(new THREE.Vector3()));
    camera.near = Math.max(size * 1e-4, dist - size * 2);
    camera.far = dist + size * 2;
    camera.updateProjectionMatrix();
  }

  // The scene's camera where it gives one; else the model's bounding sphere framed from the front,
  // a little above (the direction of isoforge render's default camera).
  function frame(info) {
    const cam = info.camera;
    if (cam) {
      camera.up.fromArray(cam.up);
      camera.fov = cam.fov;
      camera.position.fromArray(cam.eye);
      controls.target.fromArray(cam.target);
    } else if (bounds) {
      const c = bounds.getCenter(new THREE.Vector3());
      const r = Math.max(bounds.getSize(new THREE.Vector3()).length() / 2, 1e-6);
      const fov = THREE.MathUtils ? THREE.MathUtils.degToRad(camera.fov) : camera.fov * Math.PI / 180;
      const dist = r / Math.sin(Math.min(fov, fov * camera.aspect) / 2);
      camera.up.set(0, 0, 1);
      controls.target.copy(c);
      camera.position.copy(c).add(new THREE.Vector3(0, -5, 3).normalize().multiplyScalar(dist));
    }
    camera.lookAt(controls.target);
    controls.update();
    fitNearFar();
  }

  function show(id, stage, gltf) {
    if (model) {
      scene.remove(model);
      model.traverse((o) => {
        if (o.geometry) o.geometry.dispose();
        if (o.material) o.material.dispose();
      });
    }
    model = gltf.scene;
    scene.add(model);
    bounds = new THREE.Box3().setFromObject(model);
    if (bounds.isEmpty()) bounds = null;
    state.shownModel = id;
    state.shownStage = stage;
    if (!state.framed && state.server && state.server.info) {
      frame(state.server.info);
      state.framed = true;
    }
    fitNearFar();
    render();
  }

  const loader = new THREE.GLTFLoader();
  function loadModel(id, stage) {
    state.loading = id;
    fetch('model.glb?m=' + id, { cache: 'no-store' })
      .then((r) => (r.ok ? r.arrayBuffer() : Promise.reject(new Error('model.glb: HTTP ' + r.status))))
      .then((bytes) => new Promise((resolve, reject) => loader.parse(bytes, '', resolve, reject)))
      .then((gltf) => show(id, stage, gltf))
      .catch((e) => console.error(e))
      .finally(() => {
        state.loading = 0;
        if (state.server && state.server.model && state.server.model !== state.shownModel)
          loadModel(state.server.model, state.server.stage);
      });
  }

  const fmt = (n) => Number(n).toLocaleString('en-US');
  const sec = (s) => (s < 10 ? s.toFixed(2) : s.toFixed(1)) + ' s';
  function row(name, value) {
    const tr = document.createElement('tr');
    const a = document.createElement('td'), b = document.createElement('td');
    a.textContent = name;
    b.textContent = value;
    tr.append(a, b);
    return tr;
  }

  function update(s) {
    state.server = s;
    const info = s.info;
    if (info) {
      document.getElementById('input').textContent = info.input;
      if (info.background && !state.backgroundSet) {
        const css = (c) => 'rgb(' + c.map((v) => Math.round(255 * Math.min(1, Math.max(0, v)))).join(',') + ')';
        document.body.style.background =
          'linear-gradient(' + css(info.background[0]) + ',' + css(info.background[1]) + ')';
        state.backgroundSet = true;
      }
      const t = document.getElementById('summary');
      t.replaceChildren(row('model', info.stage + (info.voxel ? ', voxel ' + Number(info.voxel.toPrecision(3)) : '')),
                        row('triangles', fmt(info.triangles)), row('vertices', fmt(info.vertices)));
      if (info.check)
        t.append(row('check', [info.check.closed ? 'closed' : 'OPEN', info.check.manifold ? 'manifold' : 'NOT MANIFOLD',
                               info.check.oriented ? 'oriented' : 'NOT ORIENTED',
                               fmt(info.check.components) + ' component' + (info.check.components === 1 ? '' : 's')]
                              .join(', ')));
      const x = info.seconds;
      t.append(row('time', 'read ' + sec(x.read) + ', sample ' + sec(x.sample) + ', mesh ' + sec(x.mesh) +
                            ', encode ' + sec(x.encode)));
      const ul = document.getElementById('warnings');
      ul.replaceChildren(...info.warnings.map((w) => {
        const li = document.createElement('li');
        li.textContent = w.where + ': ' + w.message;
        return li;
      }));
    }
    const status = document.getElementById('status');
    const bar = document.getElementById('progress');
    if (s.building) {
      status.textContent = 'building: ' + s.progress_stage + ' ' + Math.round(100 * (s.progress || 0)) + '%';
      bar.style.visibility = 'visible';
      bar.firstElementChild.style.width = (100 * (s.progress || 0)) + '%';
    } else {
      status.textContent = s.error ? 'error (the last good model is shown)' : (info ? info.stage + ' model' : '');
      bar.style.visibility = 'hidden';
    }
    const err = document.getElementById('error');
    err.textContent = s.error || '';
    err.style.display = s.error ? 'block' : 'none';
    state.errorShown = s.error || '';
    if (s.model && s.model !== state.shownModel && !state.loading) loadModel(s.model, s.stage);
  }

  const events = new EventSource('events');
  events.addEventListener('state', (e) => update(JSON.parse(e.data)));
  events.onerror = () => {
    document.getElementById('status').textContent = 'disconnected: is isoforge view still running? (retrying)';
  };

  window.addEventListener('keydown', (e) => {
    if (e.key === 'h') {
      const p = document.getElementById('panel'), help = document.getElementById('help');
      const hide = p.style.display !== 'none';
      p.style.display = help.style.display = hide ? 'none' : '';
    } else if (e.key === 'f' && state.server && state.server.info) {
      frame(state.server.info);
      render();
    }
  });
  resize();
})();

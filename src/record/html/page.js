"use strict";
// groundscope's episode page: every panel drawn from the data above at the step the slider
// shows. Pictures are laid out from the atlas's tiles (drawn by groundscope's renderer), and
// the marks over them follow src/render/overlay.rs with the sizes and colours the data gives.
(() => {
  const D = JSON.parse(document.getElementById("gs-data").textContent);
  const L = D.look;
  const T = L.tile;
  const COLS = D.atlas.cols;
  const N = 7; // the view's side in cells
  const MAP_PX = 140; // a map's side on the page
  const panels = D.panels;
  const steps = Math.max(1, ...panels.map((p) => p.steps.length));
  const $ = (id) => document.getElementById(id);
  let cur = 0;
  let timer = null;

  function el(tag, cls, text) {
    const e = document.createElement(tag);
    if (cls) e.className = cls;
    if (text !== undefined) e.textContent = text;
    return e;
  }

  // src/render/heatmap.rs's colorize on 0..hi, for a value stored in thousandths of hi.
  function viridis(q) {
    return L.viridis[Math.max(0, Math.min(255, Math.floor((q / 1000) * 256)))];
  }

  // The step a panel shows: a shorter episode holds its last step.
  function shownOf(p, k) {
    return Math.min(k, p.steps.length - 1);
  }

  const atlas = new Image();

  function tile(ctx, idx, x, y) {
    ctx.drawImage(atlas, (idx % COLS) * T, Math.floor(idx / COLS) * T, T, T, x, y, T, T);
  }

  // The edge band `w` wide of the square of side `s` at (x, y).
  function band(ctx, x, y, s, w) {
    ctx.fillRect(x, y, s, w);
    ctx.fillRect(x, y + s - w, s, w);
    ctx.fillRect(x, y + w, w, s - 2 * w);
    ctx.fillRect(x + s - w, y + w, w, s - 2 * w);
  }

  // The cells the agent stood on before step k, each once, without the one it stands on.
  function trail(p, k) {
    const now = p.steps[k].ag;
    const seen = new Set();
    const out = [];
    for (let i = 0; i < k; i++) {
      const [x, y] = p.steps[i].ag;
      const c = y * p.width + x;
      if ((x !== now[0] || y !== now[1]) && !seen.has(c)) {
        seen.add(c);
        out.push(c);
      }
    }
    return out;
  }

  function drawWorld(ctx, p, k) {
    const s = p.steps[k];
    const g = p.grids[s.g];
    const w = p.width;
    const lit = new Uint8Array(w * p.height);
    for (const c of s.vis) lit[c] = 1;
    const agent = s.ag[1] * w + s.ag[0];
    const r = L.ring;
    for (let c = 0; c < w * p.height; c++) {
      const idx = c === agent ? s.at : lit[c] ? g.lit[c] : g.unlit[c];
      tile(ctx, idx, (c % w) * T, Math.floor(c / w) * T);
    }
    const at = (c) => [(c % w) * T, Math.floor(c / w) * T];
    // The trail, then M over the view's cells, then the targets: world_picture's order.
    const half = L.trail_half;
    const mid = Math.floor(T / 2);
    ctx.globalAlpha = L.trail_alpha;
    ctx.fillStyle = L.trail;
    for (const c of trail(p, k)) {
      const [x, y] = at(c);
      ctx.fillRect(x + mid - half + 1, y + mid - half + 1, 2 * half - 1, 2 * half - 1);
    }
    ctx.globalAlpha = 1;
    if (s.att) {
      for (let i = 0; i < N * N; i++) {
        const c = s.att.cells[i];
        const mark = s.att.marks[i];
        if (c < 0 || mark === "-") continue;
        const [x, y] = at(c);
        ctx.fillStyle = viridis(s.att.m[i]);
        if (mark === "T") {
          ctx.globalAlpha = L.overlay_alpha;
          ctx.fillRect(x, y, T, T);
          ctx.globalAlpha = 1;
        } else if (mark === "R") {
          band(ctx, x, y, T, r);
        } else {
          band(ctx, x + r, y + r, T - 2 * r, r);
        }
      }
    }
    ctx.fillStyle = L.target;
    const a = L.arm;
    for (const c of s.tg) {
      const [x, y] = at(c);
      for (const [dx, dy] of [[0, 0], [T - a, 0], [0, T - a], [T - a, T - a]]) {
        ctx.fillRect(x + dx, y + (dy === 0 ? 0 : T - r), a, r);
        ctx.fillRect(x + (dx === 0 ? 0 : T - r), y + dy, r, a);
      }
    }
    // Clause numbers, in their stage's colour, in a free cell beside each target.
    ctx.font = `${Math.round(T * 0.5)}px sans-serif`;
    ctx.textBaseline = "middle";
    ctx.textAlign = "center";
    for (const [c, lc, label, color] of s.cl || []) {
      const [x, y] = at(c);
      ctx.strokeStyle = color;
      ctx.lineWidth = 1.5;
      ctx.strokeRect(x + 1.75, y + 1.75, T - 3.5, T - 3.5);
      const [lx, ly] = at(lc);
      const tw = ctx.measureText(label).width;
      const th = T * 0.5;
      let cx = lx + T / 2;
      let cy = ly + T / 2;
      if (lc === c) {
        cx = x + 2 + tw / 2;
        cy = y + 1 + th / 2;
      } else {
        cx += Math.sign(x - lx) * T * 0.25;
        cy += Math.sign(y - ly) * T * 0.25;
      }
      ctx.fillStyle = "rgba(0, 0, 0, 0.67)";
      ctx.fillRect(cx - tw / 2 - 1, cy - th / 2 - 1, tw + 2, th + 2);
      ctx.fillStyle = color;
      ctx.fillText(label, cx, cy);
    }
  }

  function drawView(ctx, s) {
    for (let i = 0; i < N * N; i++) tile(ctx, s.view[i], (i % N) * T, Math.floor(i / N) * T);
  }

  // A 7×7 map as the debugger draws it: the colour map on the step's scale, the view's walls
  // and objects outlined, its unseen cells hatched, grounding marks, the agent at the bottom.
  function drawMap(ctx, q, s, which, dim) {
    const c = ctx.canvas.width / N;
    for (let i = 0; i < N * N; i++) {
      ctx.fillStyle = viridis(q[i]);
      ctx.fillRect((i % N) * c, Math.floor(i / N) * c, c, c);
    }
    for (let i = 0; i < N * N; i++) {
      const mark = D.atlas.landmarks[s.view[i]];
      if (!mark) continue;
      const x = (i % N) * c;
      const y = Math.floor(i / N) * c;
      if (mark === "u") {
        ctx.strokeStyle = "rgba(255, 255, 255, 0.27)";
        ctx.lineWidth = 1;
        ctx.beginPath();
        for (let j = 1; j < 4; j++) {
          const t = (j / 4) * c;
          ctx.moveTo(x, y + t);
          ctx.lineTo(x + t, y);
          ctx.moveTo(x + c - t, y + c);
          ctx.lineTo(x + c, y + c - t);
        }
        ctx.stroke();
      } else if (mark === "w") {
        ctx.strokeStyle = "rgba(255, 255, 255, 0.35)";
        ctx.lineWidth = 1;
        ctx.strokeRect(x + 1.5, y + 1.5, c - 3, c - 3);
      } else {
        ctx.strokeStyle = mark;
        ctx.globalAlpha = 0.75;
        ctx.lineWidth = 1.5;
        ctx.strokeRect(x + c * 0.22, y + c * 0.22, c * 0.56, c * 0.56);
        ctx.globalAlpha = 1;
      }
    }
    for (const [m, vx, vy, color] of s.att.hits || []) {
      if (m !== which) continue;
      ctx.strokeStyle = color;
      ctx.lineWidth = 2.5;
      ctx.beginPath();
      ctx.arc((vx + 0.5) * c, (vy + 0.5) * c, c * 0.42, 0, 2 * Math.PI);
      ctx.stroke();
    }
    const ax = 3.5 * c;
    const ay = 6.5 * c;
    ctx.fillStyle = "rgb(255, 80, 80)";
    ctx.beginPath();
    ctx.moveTo(ax, ay - 0.3 * c);
    ctx.lineTo(ax + 0.25 * c, ay + 0.25 * c);
    ctx.lineTo(ax - 0.25 * c, ay + 0.25 * c);
    ctx.closePath();
    ctx.fill();
    if (dim) {
      ctx.fillStyle = "rgba(40, 40, 40, 0.75)";
      ctx.fillRect(0, 0, ctx.canvas.width, ctx.canvas.height);
    }
  }

  // A map canvas that says the value under the pointer.
  function mapCanvas(view, which) {
    const cv = el("canvas", "map");
    cv.width = MAP_PX;
    cv.height = MAP_PX;
    cv.addEventListener("mousemove", (e) => {
      const s = view.step();
      if (!s.att) return;
      const box = cv.getBoundingClientRect();
      const vx = Math.floor(((e.clientX - box.left) / box.width) * N);
      const vy = Math.floor(((e.clientY - box.top) / box.height) * N);
      if (vx < 0 || vy < 0 || vx >= N || vy >= N) return;
      const q = which < 0 ? s.att.m : s.att.wd[which];
      const v = (q[vy * N + vx] / 1000) * s.att.s;
      cv.title = `view cell (${vx}, ${vy}): ${v.toFixed(4)}`;
    });
    return cv;
  }

  function buildPanel(p, pi) {
    const root = el("section", "panel");
    root.append(el("h2", null, p.title));
    root.append(el("div", "mission", p.mission));
    root.append(el("div", "meta", `${p.level} · seed ${p.seed} · ${p.mode} · ` +
      `${p.success ? "success" : "failure"} in ${p.steps.length} steps · ` +
      `total reward ${p.total_reward.toFixed(3)}`));
    const line = el("div", "line");
    const act = el("div", "line");
    const plan = el("div", "plan");
    root.append(line, act, plan);
    const body = el("div", "body");
    root.append(body);
    const pictures = el("div", "pictures");
    const world = el("canvas", "world");
    world.width = p.width * T;
    world.height = p.height * T;
    world.setAttribute("aria-label", "the world, M tinted on it");
    const view = el("canvas", "view");
    view.width = N * T;
    view.height = N * T;
    view.setAttribute("aria-label", "the agent's view");
    pictures.append(world, view);
    const columns = el("div", "columns");
    body.append(pictures, columns);
    const v = { p, pi, k: 0, step: () => p.steps[v.k] };
    const maps = [];
    let barLabels = null;
    if (p.words.length > 0) {
      const row = el("div", "maps");
      const add = (which, name) => {
        const fig = el("figure");
        const cap = el("figcaption");
        const cv = mapCanvas(v, which);
        cv.setAttribute("aria-label", `map of ${name}`);
        fig.append(cap, cv);
        row.append(fig);
        maps.push({ which, name, fig, cap, cv });
      };
      add(-1, "M");
      const bar = el("div", "colorbar");
      barLabels = [el("span"), el("span", null, "0")];
      const cb = el("canvas");
      cb.width = 1;
      cb.height = 256;
      const bctx = cb.getContext("2d");
      for (let i = 0; i < 256; i++) {
        bctx.fillStyle = L.viridis[255 - i];
        bctx.fillRect(0, i, 1, 1);
      }
      bar.append(barLabels[0], cb, barLabels[1]);
      bar.title = "every map of the step: 0 to its largest value";
      row.append(bar);
      p.words.forEach((wd, i) => add(i, wd));
      columns.append(row);
    }
    const bars = el("div", "bars");
    bars.append(el("div", "weak", "action probabilities"));
    const rows = p.actions.map((name, a) => {
      const r = el("div", "bar");
      const track = el("div", "track");
      const fill = el("div", "fill");
      track.append(fill);
      const value = el("span", "value");
      value.id = `prob-${pi}-${a}`;
      r.append(el("span", null, name), track, value);
      bars.append(r);
      return { fill, value };
    });
    const others = el("div", "weak");
    bars.append(others);
    columns.append(bars);
    const acc = el("div", "acc");
    const tree = el("div", "tree");
    columns.append(acc, tree);
    const wctx = world.getContext("2d");
    const vctx = view.getContext("2d");

    v.draw = (k) => {
      v.k = shownOf(p, k);
      const s = p.steps[v.k];
      const n = p.steps.length;
      line.textContent = `step ${v.k} of 0–${n - 1}`;
      if (k > v.k) line.append(el("span", "held", ` · the episode ended at step ${n - 1}`));
      act.textContent = `action ${L.action_names[s.a]} · value ${s.v.toFixed(3)} · ` +
        `reward ${s.r.toFixed(3)}`;
      if (p.expert) {
        const ex = s.ex === null ? "none" : L.action_names[s.ex];
        act.append(` · expert (minigrid's bot): ${ex}`);
        if (s.ex !== null && s.ex !== s.a) {
          act.append(el("span", "left-plan", " · left the expert's plan here"));
        }
      }
      plan.textContent = s.plan ? `plan: ${s.plan}` : "";
      drawWorld(wctx, p, v.k);
      drawView(vctx, s);
      if (s.att) {
        barLabels[0].textContent = s.att.s.toFixed(3);
        for (const m of maps) {
          const q = m.which < 0 ? s.att.m : s.att.wd[m.which];
          let dim = false;
          if (m.which < 0) {
            m.cap.innerHTML = "<b>M</b>\ncombined map";
          } else {
            const w = s.att.w[m.which];
            const h = s.att.h[m.which];
            dim = w < L.negligible;
            m.cap.textContent = "";
            m.cap.append(el("b", null, m.name),
              `\nw ${w.toFixed(3)} · H ${h.toFixed(2)}` + (dim ? "\nw < 0.005: not in M" : ""));
          }
          m.fig.classList.toggle("dim", dim);
          drawMap(m.cv.getContext("2d"), q, s, m.which, dim);
        }
        acc.textContent = s.att.acc;
      }
      rows.forEach((r, a) => {
        const x = s.p[a];
        r.fill.style.width = `${Math.max(0, Math.min(1, x)) * 100}%`;
        r.fill.style.background = a === s.a ? L.chosen_bar : L.bar;
        r.value.textContent = x.toFixed(3) + (a === s.ex ? " < expert" : "");
        r.value.dataset.p = String(x);
      });
      others.textContent = s.po === undefined ? ""
        : `actions this level does not have: ${s.po.toFixed(3)}`;
      tree.innerHTML = p.trees[s.tr];
    };
    return { root, v };
  }

  const main = $("panels");
  main.style.gridTemplateColumns = `repeat(${panels.length}, minmax(0, 1fr))`;
  const views = panels.map((p, i) => {
    const b = buildPanel(p, i);
    main.append(b.root);
    return b.v;
  });
  const slider = $("slider");
  slider.max = String(steps - 1);
  $("last-step").textContent = String(steps - 1);

  function render() {
    $("step").textContent = String(cur);
    slider.value = String(cur);
    document.body.dataset.step = String(cur);
    for (const v of views) v.draw(cur);
  }

  function go(k) {
    cur = Math.max(0, Math.min(steps - 1, k));
    render();
  }

  function pause() {
    if (timer !== null) clearInterval(timer);
    timer = null;
    $("play").textContent = "play";
  }

  function play() {
    pause();
    if (cur >= steps - 1) go(0);
    $("play").textContent = "pause";
    timer = setInterval(() => {
      if (cur >= steps - 1) pause();
      else go(cur + 1);
    }, 1000 / Number($("speed").value));
  }

  const toggle = () => (timer === null ? play() : pause());
  const buttons = {
    first: () => go(0),
    back: () => go(cur - 1),
    play: toggle,
    forward: () => go(cur + 1),
    last: () => go(steps - 1),
  };
  for (const [id, f] of Object.entries(buttons)) {
    $(id).addEventListener("click", (e) => {
      f();
      // Keys go to the page, not to a focused button (Space would press it again).
      e.currentTarget.blur();
    });
  }
  slider.addEventListener("input", () => go(Number(slider.value)));
  $("speed").addEventListener("change", () => {
    if (timer !== null) play();
  });
  document.addEventListener("keydown", (e) => {
    if (e.altKey || e.ctrlKey || e.metaKey || e.target === $("speed")) return;
    const keys = {
      ArrowRight: () => go(cur + 1),
      ArrowLeft: () => go(cur - 1),
      Home: () => go(0),
      End: () => go(steps - 1),
      " ": toggle,
    };
    const f = keys[e.key];
    if (!f) return;
    // The slider would move a second time on its own arrows and Home / End.
    e.preventDefault();
    f();
  });

  // The page's state, for scripts and tests.
  window.groundscope = {
    get step() { return cur; },
    steps,
    go,
    playing: () => timer !== null,
    action_probs: (panel = 0) => {
      const p = panels[panel];
      return p.steps[shownOf(p, cur)].p.slice();
    },
    weights: (panel = 0) => {
      const p = panels[panel];
      const s = p.steps[shownOf(p, cur)];
      return s.att ? s.att.w.slice() : [];
    },
  };

  // A link may name the step to open at (`page.html#step=7`: eval's report opens a failed
  // episode at its decisive step).
  const asked = /^#step=(\d+)$/.exec(window.location.hash);
  if (asked) cur = Math.max(0, Math.min(steps - 1, Number(asked[1])));

  atlas.onload = render;
  atlas.src = D.atlas.png;
})();

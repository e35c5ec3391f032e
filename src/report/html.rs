//! `report.html`: one file with every table and plot inline and a
//! per-episode drill-down (embedded JSON and a little vanilla JavaScript).
//! It references nothing outside itself: no stylesheet, font, script or
//! image is loaded, and no URL appears in it.

use super::Report;
use super::drill::{DrillData, script_json};
use crate::export::{Exporter, HtmlExporter, esc};
use std::fmt::Write;

const CSS: &str = r#"
body{font-family:Helvetica,Arial,sans-serif;margin:0;color:#222;background:#fff;line-height:1.4}
header{background:#2f3b4c;color:#fff;padding:14px 24px}
header h1{margin:0;font-size:22px}
header p{margin:4px 0 0;font-size:13px;color:#d8dee9}
nav{position:sticky;top:0;background:#f4f5f7;border-bottom:1px solid #ddd;padding:6px 24px;font-size:13px;z-index:2}
nav a{margin-right:14px;color:#2f5d8a;text-decoration:none}
main{padding:8px 24px 40px;max-width:1500px}
h2{margin-top:34px;border-bottom:2px solid #e3e3e3;padding-bottom:4px}
table.t{border-collapse:collapse;font-size:13px;margin:8px 0 4px}
table.t caption{text-align:left;font-weight:bold;padding:4px 0}
table.t th,table.t td{border:1px solid #ddd;padding:3px 8px;text-align:left;white-space:nowrap}
table.t th.num,table.t td.num{text-align:right;font-variant-numeric:tabular-nums}
table.t th{background:#f4f5f7}
table.t tbody tr:nth-child(even){background:#fafafa}
p.note{font-size:12px;color:#555;margin:2px 0 14px;max-width:1100px}
figure{margin:18px 0;overflow-x:auto}
figure svg{max-width:100%;height:auto}
figcaption{font-size:12.5px;color:#444;max-width:1000px;margin-top:4px}
.warn{background:#fff4e5;border-left:4px solid #f0a030;padding:6px 10px;font-size:13px}
#drill .controls label{margin-right:12px;font-size:13px}
#drill select{font-size:13px;margin-left:4px}
#dd-summary{margin:10px 0;font-size:13px}
#dd-summary b{font-weight:bold}
.strip{display:flex;height:16px;margin:6px 0 10px;max-width:900px}
.strip div{flex:1 1 0;margin-right:1px}
table.turns{border-collapse:collapse;font-size:12px;width:100%}
table.turns th,table.turns td{border:1px solid #ddd;padding:3px 6px;vertical-align:top;text-align:left}
table.turns th{background:#f4f5f7;position:sticky;top:30px}
table.turns pre{margin:0;white-space:pre-wrap;word-break:break-word;font-size:11.5px;max-height:260px;overflow:auto}
td.scene{width:38%}td.reply{width:26%}
.pe{color:#b00020;font-weight:bold}
.muted{color:#777}
dl.defs dt{font-weight:bold;margin-top:8px}
dl.defs dd{margin-left:16px;font-size:13.5px;max-width:1100px}
"#;

const JS: &str = r##"
(function () {
  var D = JSON.parse(document.getElementById('drill-data').textContent);
  var root = document.getElementById('drill');
  function $(id) { return document.getElementById(id); }
  function el(tag, text, cls) {
    var e = document.createElement(tag);
    if (text !== undefined && text !== null) e.textContent = String(text);
    if (cls) e.className = cls;
    return e;
  }
  var MCOL = { proceed: '#2e7d32', nudge_forward: '#f9a825', yield: '#ef6c00', stop: '#c62828' };
  var cells = {};
  D.episodes.forEach(function (e) {
    var k = e[0] + '|' + e[1] + '|' + e[2];
    (cells[k] = cells[k] || []).push(e);
  });
  var S = { model: $('dd-model'), scenario: $('dd-scenario'), tier: $('dd-tier'), seed: $('dd-seed'), rollout: $('dd-rollout') };
  function fill(sel, values, label, keep) {
    var old = keep !== undefined ? String(keep) : sel.value;
    while (sel.firstChild) sel.removeChild(sel.firstChild);
    values.forEach(function (v) {
      var o = el('option', label(v));
      o.value = String(v);
      sel.appendChild(o);
    });
    if (values.map(String).indexOf(old) >= 0) sel.value = old;
  }
  function uniq(xs) { return xs.filter(function (x, i) { return xs.indexOf(x) === i; }).sort(function (a, b) { return a - b; }); }
  function eps() { return D.episodes.filter(function (e) { return e[0] === +S.model.value; }); }
  function fillScenarios(keep) { fill(S.scenario, uniq(eps().map(function (e) { return e[1]; })), function (v) { return D.scenarios[v]; }, keep); }
  function cell() { return cells[S.model.value + '|' + S.scenario.value + '|' + S.tier.value] || []; }
  function fillTiers(keep) {
    var m = +S.model.value, s = +S.scenario.value;
    fill(S.tier, uniq(D.episodes.filter(function (e) { return e[0] === m && e[1] === s; }).map(function (e) { return e[2]; })), function (v) { return 'tier ' + v; }, keep);
  }
  function fillSeeds(keep) {
    var c = cell(), seen = {}, seeds = [];
    c.forEach(function (e) { if (!seen[e[3]]) { seen[e[3]] = { t: false, o: [] }; seeds.push(e[3]); } if (e[13] >= 0) seen[e[3]].t = true; seen[e[3]].o.push(D.outcomes[e[5]]); });
    fill(S.seed, seeds, function (v) { return v + ' (' + seen[v].o.join(', ') + ')' + (seen[v].t ? ' \u2605' : ''); }, keep);
  }
  function fillRollouts(keep) {
    var seed = S.seed.value;
    fill(S.rollout, cell().filter(function (e) { return String(e[3]) === seed; }).map(function (e) { return e[4]; }), function (v) { return 'rollout ' + v; }, keep);
    S.rollout.parentNode.style.display = S.rollout.options.length > 1 ? '' : 'none';
  }
  function current() {
    var seed = S.seed.value, r = S.rollout.value;
    return cell().filter(function (e) { return String(e[3]) === seed && String(e[4]) === r; })[0];
  }
  function f2(x) { return (Math.round(x * 100) / 100).toFixed(2); }
  function motion(p, prev, dt) {
    var s = '(' + f2(p[0]) + ', ' + f2(p[1]) + ') m, ' + f2(p[2]) + ' m/s';
    if (prev && dt > 0) {
      var a = (p[2] - prev[2]) / dt;
      s += ', ' + (a >= 0 ? '+' : '') + f2(a) + ' m/s\u00b2';
    }
    return s;
  }
  function esc(x) { return String(x).replace(/&/g, '&amp;').replace(/</g, '&lt;').replace(/>/g, '&gt;').replace(/"/g, '&quot;'); }
  function svgText(x, y, text, color, anchor) {
    return '<text x="' + f2(x) + '" y="' + f2(y) + '" font-size="10" fill="' + (color || '#555') + '"' +
      (anchor ? ' text-anchor="' + anchor + '"' : '') + '>' + esc(text) + '</text>';
  }
  function line(pts, color, dash) {
    return '<polyline fill="none" stroke-width="2" stroke="' + color + '"' + (dash ? ' stroke-dasharray="5 3"' : '') +
      ' points="' + pts.join(' ') + '"></polyline>';
  }
  function hline(x0, x1, y) { return '<line x1="' + f2(x0) + '" x2="' + f2(x1) + '" y1="' + f2(y) + '" y2="' + f2(y) + '" stroke="#9e9e9e" stroke-dasharray="5 2"></line>'; }
  // The plan view of the embedded positions: the ego solid, the others dashed, equal aspect, and the
  // lines of a lateral frame (the kerbs). Built as markup (numbers only), so the page names no namespace URL.
  function drawTrajectory(T, box, scene) {
    var ego = [], others = [];
    T.turns.forEach(function (t) {
      if (t.ego) ego.push(t.ego);
      (t.o || []).forEach(function (p, k) { (others[k] = others[k] || []).push(p); });
    });
    var all = ego.concat.apply(ego, others);
    if (all.length < 2) { box.appendChild(el('p', 'No positions recorded for this episode.', 'muted')); return; }
    var marks = [];
    scene.lateral.forEach(function (f) { if (f) f.marks.forEach(function (m) { marks.push([m[0] - f.offset, m[1]]); }); });
    var xs = all.map(function (p) { return p[0]; }), ys = all.map(function (p) { return p[1]; }).concat(marks.map(function (m) { return m[0]; }));
    var x0 = Math.min.apply(null, xs), x1 = Math.max.apply(null, xs), y0 = Math.min.apply(null, ys), y1 = Math.max.apply(null, ys);
    var span = Math.max(x1 - x0, y1 - y0, 10) * 1.1, cx = (x0 + x1) / 2, cy = (y0 + y1) / 2, W = 260;
    function px(x) { return (x - cx) / span * W + W / 2; }
    function py(y) { return W / 2 - (y - cy) / span * W; }
    function pt(p) { return f2(px(p[0])) + ',' + f2(py(p[1])); }
    var svg = '<svg viewBox="0 0 ' + W + ' ' + W + '" width="' + W + '" height="' + W + '" role="img">' +
      '<rect width="' + W + '" height="' + W + '" fill="#fafafa"></rect>';
    // The lower line's label below it, the other's above: the road (and the ego's path) lies between.
    var lowest = Math.min.apply(null, marks.map(function (m) { return m[0]; }));
    marks.forEach(function (m) { svg += hline(0, W, py(m[0])) + svgText(4, py(m[0]) + (m[0] === lowest ? 11 : -3), m[1]); });
    others.forEach(function (ps, k) {
      svg += line(ps.map(pt), k ? '#7f7f7f' : '#c0704a', true);
      svg += svgText(px(ps[0][0]) + 6, py(ps[0][1]) - 6, scene.roles[k] || 'road user ' + (k + 1), k ? '#7f7f7f' : '#c0704a');
    });
    svg += line(ego.map(pt), '#6a3d9a', false) + '</svg>';
    box.innerHTML = svg;
    scene.lateral.forEach(function (f, k) { if (f) box.innerHTML += lateralPanel(T, f, k, scene.roles[k]); });
    box.appendChild(el('div', 'Plan view at the decision turns: ego solid, ' + (scene.roles.join(', ') || 'other road users') +
      ' dashed (m, equal aspect)' + (scene.lateral.some(function (f) { return f; }) ? '; beside it, the ' +
      scene.roles.filter(function (r, k) { return scene.lateral[k]; }).join(', ') + ' in the scene text\'s lateral frame.' : '.'), 'muted'));
  }
  // A road user's position over the turns in its lateral frame (the pedestrian from the near kerb, the
  // numbers the scene text gave), with the frame's lines and the band where it is in the ego's path.
  function lateralPanel(T, f, k, role) {
    var pts = T.turns.filter(function (t) { return t.f && t.f[k] !== null && t.f[k] !== undefined; })
      .map(function (t) { return [t.time !== undefined ? t.time : (t.t - 1) * 0.5, t.f[k]]; });
    var W = 380, H = 260, L = 40, R = 300, top = 24, bot = 230;
    var vs = pts.map(function (p) { return p[1]; }).concat([f.marks[0][0] - 1, f.marks[1][0] + 0.5]);
    var lo = Math.min.apply(null, vs), hi = Math.max.apply(null, vs);
    var tEnd = Math.max.apply(null, pts.map(function (p) { return p[0]; }).concat([0.5]));
    function sx(t) { return L + t / tEnd * (R - L); }
    function sy(v) { return bot - (v - lo) / (hi - lo) * (bot - top); }
    var svg = '<svg viewBox="0 0 ' + W + ' ' + H + '" width="' + W + '" height="' + H + '" role="img" class="lateral" data-role="' + esc(role) + '">' +
      '<rect x="' + L + '" y="' + top + '" width="' + (R - L) + '" height="' + (bot - top) + '" fill="#fafafa"></rect>' +
      '<rect x="' + L + '" y="' + f2(sy(f.path[1])) + '" width="' + (R - L) + '" height="' + f2(sy(f.path[0]) - sy(f.path[1])) +
      '" fill="#c0704a" fill-opacity="0.12"></rect>' +
      svgText(L + 4, sy(f.path[1]) + 11, 'in the ego\'s path (' + f.path[0].toFixed(1) + '\u2013' + f.path[1].toFixed(1) + ' m)', '#c0704a');
    f.marks.forEach(function (m) { svg += hline(L, R, sy(m[0])) + svgText(R + 4, sy(m[0]) + 3.5, m[1] + ' (' + m[0] + ')'); });
    for (var v = Math.ceil(lo / 2) * 2; v <= hi; v += 2) svg += svgText(L - 4, sy(v) + 3.5, v, '#555', 'end');
    svg += line(pts.map(function (p) { return f2(sx(p[0])) + ',' + f2(sy(p[1])); }), '#c0704a', true);
    svg += svgText(L, 14, role + ', ' + f.measured + ' (m), as the scene text gives it', '#222');
    svg += svgText(L, bot + 16, '0', '#555', 'middle') + svgText(R, bot + 16, f2(tEnd) + ' s', '#555', 'middle');
    return svg + '</svg>';
  }
  function render() {
    var e = current(), sum = $('dd-summary'), body = $('dd-turns'), strip = $('dd-strip'), note = $('dd-note'), traj = $('dd-traj');
    [sum, body, strip, note, traj].forEach(function (n) { while (n.firstChild) n.removeChild(n.firstChild); });
    // Reset first, so an episode without a transcript never shows the previous one's count.
    $('dd-count').textContent = '0';
    if (!e) { root.setAttribute('data-state', 'empty'); return; }
    var parts = [['model', D.models[e[0]]], ['scenario', D.scenarios[e[1]]], ['tier', e[2]], ['seed', e[3]], ['rollout', e[4]],
      ['outcome', D.outcomes[e[5]]], ['hidden disposition (privileged)', D.dispositions[e[6]]], ['reward', f2(e[7])],
      ['decision correctness', f2(e[8])], ['turns', e[9]], ['parse-error turns', e[10]], ['tokens', e[11]], ['latency', (e[12] / 1000).toFixed(2) + ' s']];
    parts.forEach(function (p, i) {
      if (i) sum.appendChild(document.createTextNode(' \u00b7 '));
      sum.appendChild(el('span', p[0] + ': '));
      sum.appendChild(el('b', p[1]));
    });
    var src = D.runs[e[14]] + ' line ' + e[15];
    if (e[13] < 0) {
      note.textContent = 'No transcript embedded for this episode: report.html carries the transcripts of up to ' + D.per_cell +
        ' episodes per model, scenario and tier (seeds marked \u2605). The full record is ' + src + '.';
      root.setAttribute('data-state', 'summary');
      root.setAttribute('data-episode', [e[0], e[1], e[2], e[3], e[4]].join('|'));
      return;
    }
    note.textContent = 'Full record: ' + src + '.';
    var T = D.transcripts[e[13]];
    var scene = D.scenes[e[1]];
    drawTrajectory(T, traj, scene);
    T.turns.forEach(function (t) {
      var d = el('div');
      d.style.background = MCOL[t.m] || '#999';
      d.title = 'turn ' + t.t + ': ' + t.m + (t.e ? ' (parse error)' : '');
      if (t.e) d.style.borderTop = '3px solid #000';
      strip.appendChild(d);
    });
    // Scene lines present in every turn (scenario, situation) are shown on the first turn only.
    var fixed = {};
    (T.turns[0] ? T.turns[0].s : []).forEach(function (i) {
      if (T.turns.every(function (t) { return t.s.indexOf(i) >= 0; })) fixed[i] = true;
    });
    var prev = null, prevTime = null;
    T.turns.forEach(function (t, n) {
      var tr = el('tr', null, 'turn-row');
      tr.appendChild(el('td', t.t));
      tr.appendChild(el('td', t.time !== undefined ? f2(t.time) : ''));
      var sc = el('td', null, 'scene');
      if (T.g) {
        var img = el('img');
        img.src = T.g + '-' + t.t + '.png'; img.width = 256; img.height = 256; img.loading = 'lazy';
        img.alt = 'the picture the model was shown at turn ' + t.t;
        sc.appendChild(img);
      }
      var lines = n === 0 ? t.s : t.s.filter(function (i) { return !fixed[i]; });
      if (lines.length < t.s.length) sc.appendChild(el('div', '(' + (t.s.length - lines.length) + ' unchanged lines as in turn 1)', 'muted'));
      sc.appendChild(el('pre', lines.map(function (i) { return D.strings[i]; }).join('\n')));
      tr.appendChild(sc);
      var rp = el('td', null, 'reply');
      rp.appendChild(el('pre', t.r === null || t.r === undefined ? '(no reply content)' : t.r));
      if (t.z) { var z = el('details'); z.appendChild(el('summary', 'provider reasoning')); z.appendChild(el('pre', t.z)); rp.appendChild(z); }
      tr.appendChild(rp);
      var ac = el('td');
      var mm = el('b', t.m); mm.style.color = MCOL[t.m] || '#222'; ac.appendChild(mm);
      ac.appendChild(document.createTextNode(' ' + f2(t.a)));
      (t.e || []).forEach(function (x) { ac.appendChild(el('div', 'parse error: ' + x, 'pe')); });
      var ideal = t.ib !== undefined ? 'ideal belief ' + f2(t.ib) : '';
      if (T.p) ac.appendChild(el('div', 'belief ' + (t.b !== undefined ? f2(t.b) : 'none (probe parse error)') + (ideal ? ', ' + ideal : ''), t.b !== undefined ? 'muted' : 'pe'));
      else if (ideal) ac.appendChild(el('div', ideal, 'muted'));
      if (T.ev === t.t) ac.appendChild(el('div', 'evidence turn', 'pe'));
      tr.appendChild(ac);
      var dt = (t.time !== undefined && prevTime !== null) ? t.time - prevTime : 0;
      var ot = el('td');
      (t.o || []).forEach(function (p, k) {
        var f = scene.lateral[k], role = (scene.roles[k] || 'road user ' + (k + 1)) + ': ';
        var before = prev && prev.o ? prev.o[k] : null;
        // A road user with a lateral frame is given in it, as the scene text gives it (its y is the plan view's).
        if (f && t.f && t.f[k] !== null) ot.appendChild(el('div', role + f2(t.f[k]) + ' m ' + f.measured + ', ' + motion(p, before, dt).split(' m, ').slice(1).join(' m, ')));
        else ot.appendChild(el('div', role + motion(p, before, dt)));
      });
      if (t.ego) ot.appendChild(el('div', 'ego: ' + motion(t.ego, prev ? prev.ego : null, dt), 'muted'));
      tr.appendChild(ot);
      tr.appendChild(el('td', t.k + ' tok, ' + t.l + ' ms' + (t.n > 1 ? ', ' + t.n + ' attempts' : '')));
      body.appendChild(tr);
      prev = t; prevTime = t.time !== undefined ? t.time : prevTime;
    });
    root.setAttribute('data-state', 'rendered');
    root.setAttribute('data-episode', [e[0], e[1], e[2], e[3], e[4]].join('|'));
    $('dd-count').textContent = String(T.turns.length);
  }
  S.model.onchange = function () { fillScenarios(); fillTiers(); fillSeeds(); fillRollouts(); render(); };
  S.scenario.onchange = function () { fillTiers(); fillSeeds(); fillRollouts(); render(); };
  S.tier.onchange = function () { fillSeeds(); fillRollouts(); render(); };
  S.seed.onchange = function () { fillRollouts(); render(); };
  S.rollout.onchange = render;
  fill(S.model, uniq(D.episodes.map(function (e) { return e[0]; })), function (v) { return D.models[v]; });
  var first = D.episodes.filter(function (e) { return e[13] >= 0; })[0] || D.episodes[0];
  if (first) {
    S.model.value = String(first[0]);
    fillScenarios(first[1]); fillTiers(first[2]); fillSeeds(first[3]); fillRollouts(first[4]);
  }
  render();
  // A link to one episode: report.html#episode=MODEL|SCENARIO|TIER|SEED|ROLLOUT (indices as in the data).
  if (location.hash.indexOf('#episode=') === 0) {
    var want = decodeURIComponent(location.hash.slice(9)).split('|');
    if (want.length === 5) {
      S.model.value = want[0];
      fillScenarios(want[1]); fillTiers(want[2]); fillSeeds(want[3]); fillRollouts(want[4]);
      render();
    }
  }
})();
"##;

/// The whole page.
pub(crate) fn render(report: &Report, drill: &DrillData) -> String {
    let mut s = String::with_capacity(1 << 20);
    let _ = write!(
        s,
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><meta name=\"viewport\" \
         content=\"width=device-width, initial-scale=1\"><title>negotiator report</title><style>{CSS}</style></head><body>"
    );
    let models: Vec<&str> = report.leaderboard.rows.iter().map(|r| r.model.as_str()).collect();
    let _ = write!(
        s,
        "<header><h1>negotiator report</h1><p>{} model(s): {} · {} run director{} · {} episodes · leaderboard scope: {} · \
         {} bootstrap resamples · negotiator {}</p></header>",
        models.len(),
        esc(&models.join(", ")),
        report.runs.len(),
        if report.runs.len() == 1 { "y" } else { "ies" },
        report.runs.iter().map(|r| r.episodes).sum::<usize>(),
        esc(&super::tables::tiers_label(&report.tiers)),
        report.resamples,
        esc(report.negotiator_version)
    );
    s.push_str(
        "<nav><a href=\"#leaderboard\">Leaderboard</a><a href=\"#figures\">Figures</a><a href=\"#tiers\">Per tier</a>\
         <a href=\"#outcomes\">Outcomes</a><a href=\"#errors\">Errors &amp; cost</a>",
    );
    if !report.paired.is_empty() {
        s.push_str("<a href=\"#paired\">Paired</a>");
    }
    if !report.pass_k.is_empty() {
        s.push_str("<a href=\"#passk\">pass^k</a>");
    }
    s.push_str("<a href=\"#trajectories\">Trajectories</a><a href=\"#drill\">Episode drill-down</a><a href=\"#runs\">Runs</a><a href=\"#definitions\">Definitions</a></nav><main>");
    for w in &report.warnings {
        let _ = write!(s, "<p class=\"warn\">{}</p>", esc(w));
    }
    let tables = report.tables();
    let table = |name: &str| tables.iter().find(|t| t.name == name).map(|t| HtmlExporter.render(t)).unwrap_or_default();
    let _ = write!(s, "<h2 id=\"leaderboard\">Leaderboard</h2>{}", table("leaderboard"));
    s.push_str("<h2 id=\"figures\">Figures</h2>");
    for p in report.plots.iter().filter(|p| !is_episode_figure(p)) {
        figure(&mut s, p);
    }
    let _ = write!(s, "<h2 id=\"tiers\">Per tier</h2>{}", table("tiers"));
    let _ = write!(s, "<h2 id=\"outcomes\">Outcome decomposition</h2>{}", table("outcomes"));
    let _ = write!(s, "<h2 id=\"errors\">Errors, tokens and latency</h2>{}", table("errors_cost"));
    if !report.paired.is_empty() {
        let _ = write!(s, "<h2 id=\"paired\">Paired comparisons</h2>{}", table("paired"));
    }
    if !report.pass_k.is_empty() {
        let _ = write!(s, "<h2 id=\"passk\">pass^k</h2>{}", table("pass_k"));
    }
    s.push_str("<h2 id=\"trajectories\">Trajectories</h2>");
    let trajectories: Vec<_> = report.plots.iter().filter(|p| is_episode_figure(p)).collect();
    if trajectories.is_empty() {
        s.push_str("<p class=\"note\">No episode with recorded turns to draw.</p>");
    } else if !report.plots.iter().any(|p| p.name.starts_with("trajectory_")) {
        s.push_str("<p class=\"note\">No episode with a recorded trajectory (runs made with --no-trajectories): maneuver timelines only.</p>");
    }
    for p in trajectories {
        figure(&mut s, p);
    }
    drill_section(&mut s, drill);
    s.push_str("<h2 id=\"runs\">Runs</h2>");
    s.push_str(&HtmlExporter.render(&report.runs_table()));
    s.push_str("<h2 id=\"definitions\">Definitions</h2><dl class=\"defs\">");
    for (term, def) in super::definitions() {
        let _ = write!(s, "<dt>{}</dt><dd>{}</dd>", esc(&term), esc(&def));
    }
    s.push_str("</dl></main>");
    let _ = write!(s, "<script type=\"application/json\" id=\"drill-data\">{}</script>", script_json(drill));
    let _ = writeln!(s, "<script>{JS}</script></body></html>");
    s
}

/// The drill-down's controls and empty turn table; the page's script fills
/// them from the embedded data.
fn drill_section(s: &mut String, drill: &DrillData) {
    let _ = write!(
        s,
        "<h2>Episode drill-down</h2><div id=\"drill\" data-state=\"loading\"><div class=\"controls\">\
         <label>model<select id=\"dd-model\"></select></label><label>scenario<select id=\"dd-scenario\"></select></label>\
         <label>tier<select id=\"dd-tier\"></select></label><label>seed<select id=\"dd-seed\"></select></label>\
         <label>rollout<select id=\"dd-rollout\"></select></label></div>\
         <p class=\"note\">Every episode's figures are here; transcripts (★) for up to {} episodes per model, scenario \
         and tier (the first collision, timeout and success by seed, then the lowest seeds; {} in this file{}). \
         Replies longer than {} characters are cut.</p>\
         <div id=\"dd-summary\"></div><div id=\"dd-strip\" class=\"strip\"></div><p id=\"dd-note\" class=\"note\"></p>\
         <div id=\"dd-traj\"></div>\
         <table class=\"turns\"><thead><tr><th>turn</th><th>t (s)</th><th>scene (what the model read)</th>\
         <th>raw reply</th><th>parsed action</th><th>other road user(s): position, speed, acceleration</th>\
         <th>cost</th></tr></thead><tbody id=\"dd-turns\"></tbody></table><p class=\"muted\"><span id=\"dd-count\">0</span> turns shown.</p></div>",
        drill.per_cell(),
        drill.transcripts(),
        if drill.dropped() > 0 {
            format!(", {} more left out by the size budget", drill.dropped())
        } else {
            String::new()
        },
        super::drill::MAX_TEXT
    );
}

/// Figures of single episodes (trajectories, maneuver timelines): they go
/// in the Trajectories section.
fn is_episode_figure(p: &super::plots::Plot) -> bool {
    p.name.starts_with("trajectory_") || p.name.starts_with("timeline_")
}

fn figure(s: &mut String, p: &super::plots::Plot) {
    let _ =
        write!(s, "<figure id=\"fig-{}\">{}<figcaption>{}</figcaption></figure>", esc(&p.name), p.svg, esc(&p.caption));
}

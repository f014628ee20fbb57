// Plot a drawing with saxi (npm package, 0.15) on the project's EBB emulator, for plotter-cli/benches/vs_saxi.sh.
// Usage: node vs_saxi_drive.js SAXI_DIR PTY DRAWING.svg
// DRAWING.svg is `plotter convert` output: <polyline>/<polygon> points in millimetres (1 user unit = 1 mm), the
// same polylines our `plotter plot` draws. saxi then does what its server does for a plot with its default options
// (`defaultPlanOptions`): reorder the paths (optimize-paths `reorder`, saxi's `sortPaths: true`: greedy nearest
// next path, either direction), join paths whose ends are within 0.5 mm (`merge`, `pathJoinRadius`), and plan them
// with pen down 50 mm/s at 200 mm/s² (cornering factor 0.127 mm), pen up 200 mm/s at 400 mm/s², pen lift and
// drop 0.12 s each (its `AxidrawFast` profile, equal to the defaults); the plan runs through its EBB class with
// microstepping mode 2, as its server does. Prints `paths N lifts N planned S` and `done`.
'use strict';
const fs = require('fs');
const board = require('../../tests/fixtures/saxi_board');

const [saxiDir, port, drawing] = process.argv.slice(2);
const { planning, ebb } = board.open(saxiDir, port);
const optimize = require(require.resolve('optimize-paths', { paths: [saxiDir] }));

const svg = fs.readFileSync(drawing, 'utf8');
let paths = [];
for (const m of svg.matchAll(/<(polyline|polygon) points="([^"]*)"/g)) {
  const pts = m[2].trim().split(/\s+/).map((p) => {
    const [x, y] = p.split(',').map(Number);
    return { x, y };
  });
  if (m[1] === 'polygon') pts.push(pts[0]);
  if (pts.length >= 2) paths.push(pts);
}
const input = paths.length;
paths = optimize.reorder(paths);
paths = optimize.merge(paths, planning.defaultPlanOptions.pathJoinRadius);
const unitsPerMm = planning.Device.Axidraw.stepsPerMm;
paths = paths.map((ps) => ps.map((p) => ({ x: p.x * unitsPerMm, y: p.y * unitsPerMm })));
const plan = planning.plan(paths, planning.AxidrawFast);

// Where saxi's planned time goes: saxi's plan is, per path, [travel, drop, draw, lift], then the travel home and
// the last pen move; XY motions between a drop and a lift draw.
const parts = { draw: 0, travel: 0, pen: 0 };
let down = false; // the pen after the last pen motion
for (const m of plan.motions) {
  if (m instanceof planning.PenMotion) {
    parts.pen += m.duration();
    down = m.finalPos === planning.AxidrawFast.penDownPos;
  } else {
    parts[down ? 'draw' : 'travel'] += m.duration();
  }
}
const fmt = (x) => x.toFixed(3);
board.run(
  ebb,
  plan,
  () =>
    `paths ${input} lifts ${paths.length} planned ${fmt(plan.duration())} draw ${fmt(parts.draw)} ` +
    `travel ${fmt(parts.travel)} pen ${fmt(parts.pen)}`,
);

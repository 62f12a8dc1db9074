// node dark_colors.mjs <harness folder> <atlas> <skeleton.json|.skel> <anim> <t1,t2,...>
// Each slot's dark colour (two-colour tint) as the official runtime holds it, in the setup pose
// and at each time of <anim>: the harness's dump (../shared/tools/spine-runtime) does not write it.
// Loads and plays the project with the harness's own runtime module (lib/runtime.mjs: the
// runtime of the skeleton's version, an AnimationState stepped from 0 to each time at 60 steps a
// second, as dump.mjs plays it). Writes to stdout:
//   {"runtime", "poses": [{"label", "dark": {slot name: [r, g, b] or null}}]}
// null: the slot has no dark colour (the runtimes then draw it with its light colour alone).
import path from "node:path";
import { pathToFileURL } from "node:url";

const [harness, atlasFile, skeletonFile, anim, times = ""] = process.argv.slice(2);
if (!anim) {
  console.error("usage: node dark_colors.mjs <harness folder> <atlas> <skeleton> <anim> <t1,t2,...>");
  process.exit(2);
}
const rt = await import(pathToFileURL(path.join(harness, "lib", "runtime.mjs")).href);
const proj = rt.loadProject(atlasFile, skeletonFile);
const sk = rt.newSkeleton(proj);

function darks() {
  const out = {};
  for (const slot of sk.slots) {
    const d = slot.darkColor;
    out[slot.data.name] = d ? [d.r, d.g, d.b].map((x) => Math.round(x * 1e6) / 1e6) : null;
  }
  return out;
}

rt.poseSetup(proj, sk);
const poses = [{ label: "setup", dark: darks() }];
for (const t of times.split(",").filter((x) => x !== "").map(Number)) {
  rt.poseAnimation(proj, sk, anim, t, 60);
  poses.push({ label: `${anim}@${t}`, dark: darks() });
}
process.stdout.write(JSON.stringify({ runtime: proj.runtime, poses }) + "\n");

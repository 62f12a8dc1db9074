// node pose.mjs <atlas> <skeleton.json|.skel> <out.json> <anim@time,...> [skin]
// Plays each pose as the 3.8-4.2 harness's dump.mjs does, with the official Spine 4.3 runtime:
// the setup pose with physics reset, then a looping AnimationState stepped from 0 to the time in
// round(time * 60) equal steps (skeleton clock carried from pose to pose). Writes the harness's
// layout: {"poses": [{"label", "anim", "time", "bones": {name: [a, b, c, d, worldX, worldY]},
// "attachments": [{"slot", "attachment", "type", "vertices", "color", ["dark"]}]}]} (setup pose first).
// "color": the light colour drawn (the slot's times the attachment's, RGBA); "dark": the slot's
// dark colour (two-colour tint, RGB), only where the slot has one.
import fs from "node:fs";
import { loadSkeletonData, spine } from "./load.mjs";

const [atlasFile, skeletonFile, outFile, poseList = "", skinName] = process.argv.slice(2);
if (!outFile) {
  console.error("usage: node pose.mjs <atlas> <skeleton.json|.skel> <out.json> <anim@time,...> [skin]");
  process.exit(2);
}
const data = loadSkeletonData(skeletonFile, atlasFile);
const skeleton = new spine.Skeleton(data);
if (skinName) skeleton.setSkin(skinName);
skeleton.setupPose();
skeleton.updateWorldTransform(spine.Physics.reset);
const r6 = (x) => Math.round(x * 1e6) / 1e6;

function bones() {
  const out = {};
  for (const b of skeleton.bones) {
    const p = b.appliedPose;
    out[b.data.name] = [p.a, p.b, p.c, p.d, p.worldX, p.worldY].map(r6);
  }
  return out;
}

/** The colours an attachment is drawn with: light (slot x attachment) and, where the slot has one, dark. */
function colours(pose, att) {
  const c = pose.color, a = att.color, d = pose.darkColor;
  const out = { color: [c.r * a.r, c.g * a.g, c.b * a.b, c.a * a.a].map(r6) };
  if (d) out.dark = [d.r, d.g, d.b].map(r6);
  return out;
}

function attachments() {
  const out = [];
  for (const slot of skeleton.drawOrder.appliedPose ?? skeleton.drawOrder) {
    const pose = slot.appliedPose, att = pose.attachment;
    if (!att || !slot.bone.active) continue;
    if (att instanceof spine.RegionAttachment) {
      const v = new Array(8).fill(0);
      att.computeWorldVertices(slot, att.getOffsets(pose), v, 0, 2);
      out.push({ slot: slot.data.name, attachment: att.name, type: "region", vertices: v.map(r6),
        ...colours(pose, att) });
    } else if (att instanceof spine.MeshAttachment) {
      const v = new Array(att.worldVerticesLength).fill(0);
      att.computeWorldVertices(skeleton, slot, 0, att.worldVerticesLength, v, 0, 2);
      out.push({ slot: slot.data.name, attachment: att.name, type: "mesh", vertices: v.map(r6),
        ...colours(pose, att) });
    }
  }
  return out;
}

const poses = [{ label: "setup", anim: null, time: 0, bones: bones(), attachments: attachments() }];
for (const item of poseList.split(",").filter(Boolean)) {
  const at = item.lastIndexOf("@");
  const anim = item.slice(0, at), time = Number(item.slice(at + 1));
  skeleton.setupPose();
  skeleton.updateWorldTransform(spine.Physics.reset);
  const state = new spine.AnimationState(new spine.AnimationStateData(data));
  state.setAnimation(0, anim, true);
  const steps = Math.max(0, Math.round(time * 60));
  const dt = steps ? time / steps : 0;
  state.apply(skeleton);
  skeleton.updateWorldTransform(spine.Physics.update);
  for (let i = 0; i < steps; i++) {
    state.update(dt);
    skeleton.update(dt);
    state.apply(skeleton);
    skeleton.updateWorldTransform(spine.Physics.update);
  }
  poses.push({ label: item, anim, time, bones: bones(), attachments: attachments() });
}
fs.writeFileSync(outFile, JSON.stringify({ poses }));

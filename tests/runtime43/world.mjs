// node world.mjs <atlas> <skeleton.json|.skel> <out.json>
// Loads a skeleton with its atlas in the official Spine 4.3 runtime, poses the setup pose
// and writes, for every region and mesh attachment of every skin, the world positions of
// its vertices and their texture coordinates (UVs on the atlas page), as the runtime
// computes them to draw: {"skin\tslot\tname": {"type", "world": [x, y, ...], "uvs": [u, v, ...]}}.
import fs from "node:fs";
import { loadSkeletonData, spine } from "./load.mjs";

const [atlasFile, skeletonFile, outFile] = process.argv.slice(2);
if (!outFile) {
  console.error("usage: node world.mjs <atlas> <skeleton.json|.skel> <out.json>");
  process.exit(2);
}
const data = loadSkeletonData(skeletonFile, atlasFile);
const skeleton = new spine.Skeleton(data);
skeleton.setupPose();
skeleton.updateWorldTransform(spine.Physics.none);
const out = {};
for (const skin of data.skins) {
  for (const { slotIndex, placeholder: name, attachment } of skin.getAttachments()) {
    const slot = skeleton.slots[slotIndex];
    const key = `${skin.name}\t${slot.data.name}\t${name}`;
    // The frame the setup pose shows (a sequence's setup index).
    const index = attachment.sequence ? attachment.sequence.resolveIndex(slot.pose) : 0;
    if (attachment instanceof spine.RegionAttachment) {
      const world = new Array(8).fill(0);
      attachment.computeWorldVertices(slot, attachment.sequence.offsets[index], world, 0, 2);
      out[key] = { type: "region", world, uvs: Array.from(attachment.sequence.getUVs(index)) };
    } else if (attachment instanceof spine.MeshAttachment) {
      const world = new Array(attachment.worldVerticesLength).fill(0);
      attachment.computeWorldVertices(skeleton, slot, 0, attachment.worldVerticesLength, world, 0, 2);
      out[key] = { type: "mesh", world, uvs: Array.from(attachment.sequence.getUVs(index)),
        triangles: Array.from(attachment.triangles) };
    }
  }
}
fs.writeFileSync(outFile, JSON.stringify(out));

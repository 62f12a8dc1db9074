// node data.mjs <skeleton.json|.skel> <out.json>
// Writes everything the official 4.3 runtime loaded into SkeletonData, as plain JSON:
// bones, slots, constraints, skins with their attachments, events, animations with every
// timeline's frames and curves. Objects that other objects refer to (bones, slots,
// constraints, skins, events, animations, attachments) appear in full once, and by name
// ("@Type:name") where referred to, so that the dumps of two loads can be compared field
// by field.
import fs from "node:fs";
import { loadSkeletonData, spine } from "./load.mjs";

const [skeletonFile, outFile] = process.argv.slice(2);
if (!skeletonFile || !outFile) {
  console.error("usage: node data.mjs <skeleton.json|.skel> <out.json>");
  process.exit(2);
}
// Not data: running counters (id), the hash (base64 in JSON, hex in binary), caches.
const SKIP = new Set(["id", "hash", "regions", "texture", "rendererObject", "timelineAttachment"]);
const REFERENCED = [spine.BoneData, spine.SlotData, spine.ConstraintData, spine.Skin, spine.EventData,
  spine.Animation, spine.Attachment];

function ser(v, top) {
  if (v === null || v === undefined) return null;
  if (typeof v === "number") return Number.isFinite(v) ? v : String(v);
  if (typeof v === "string" || typeof v === "boolean") return v;
  if (typeof v === "function") return undefined;
  if (ArrayBuffer.isView(v) || Array.isArray(v)) return Array.from(v, (x) => ser(x, false));
  if (v instanceof Map) return Object.fromEntries([...v].map(([k, x]) => [k, ser(x, false)]));
  if (!top && REFERENCED.some((T) => v instanceof T)) return `@${v.constructor.name}:${v.name}`;
  const out = { class: v.constructor.name };
  for (const k of Object.keys(v).sort()) {
    if (SKIP.has(k)) continue;
    const x = ser(v[k], false);
    if (x !== undefined) out[k] = x;
  }
  return out;
}

function skin(s) {
  const entries = s.getAttachments().map((e) => [e.slotIndex, e.placeholder, ser(e.attachment, true)]);
  entries.sort((a, b) => a[0] - b[0] || (a[1] < b[1] ? -1 : a[1] > b[1] ? 1 : 0));
  return { name: s.name, bones: s.bones.map((b) => b.name), constraints: s.constraints.map((c) => c.name),
    color: ser(s.color, false), attachments: entries };
}

const data = loadSkeletonData(skeletonFile);
const out = {
  skeleton: Object.fromEntries(["version", "x", "y", "width", "height", "referenceScale", "fps", "imagesPath",
    "audioPath"].map((k) => [k, ser(data[k], false)])),
  bones: data.bones.map((b) => ser(b, true)),
  slots: data.slots.map((s) => ser(s, true)),
  constraints: data.constraints.map((c) => ser(c, true)),
  skins: data.skins.map(skin),
  defaultSkin: data.defaultSkin ? data.defaultSkin.name : null,
  events: data.events.map((e) => ser(e, true)),
  animations: data.animations.map((a) => ser(a, true)),
};
fs.writeFileSync(outFile, JSON.stringify(out));

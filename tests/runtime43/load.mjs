// Shared by the harness scripts: load a skeleton (.json or .skel) with the official
// Spine 4.3 runtime, with the regions of an atlas or, without one, stand-in regions.
import fs from "node:fs";
import * as spine from "@esotericsoftware/spine-core";

/** A loader whose every region is a whole 64 x 64 page: enough to load skeleton data. */
class StandInLoader extends spine.AtlasAttachmentLoader {
  constructor() {
    super(new spine.TextureAtlas(""), true);
  }
  findRegion(name, path) {
    return { u: 0, v: 0, u2: 1, v2: 1, width: 64, height: 64, originalWidth: 64, originalHeight: 64,
      offsetX: 0, offsetY: 0, degrees: 0, name: path, texture: null };
  }
}

export function loadSkeletonData(skeletonFile, atlasFile) {
  const loader = atlasFile
    ? new spine.AtlasAttachmentLoader(new spine.TextureAtlas(fs.readFileSync(atlasFile, "utf8")))
    : new StandInLoader();
  const bytes = fs.readFileSync(skeletonFile);
  if (skeletonFile.toLowerCase().endsWith(".json")) {
    const text = bytes.toString("utf8").replace(/^\uFEFF/, "");
    return new spine.SkeletonJson(loader).readSkeletonData(text);
  }
  const view = new Uint8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  return new spine.SkeletonBinary(loader).readSkeletonData(view.slice());
}

export { spine };

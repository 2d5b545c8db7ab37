"""Picture bakes (a job source of tussock.bake / tussock.free_bake, see addon/cache.py).

An animated picture is drawn by the compositor from images Tussock writes: the background
plate and the layers at rest (once), and per layer a UV pass every frame. A bake writes them
as OpenEXR files beside the .blend and points the compositor's Image nodes at them, the UV
passes as image sequences, so a Blender without Tussock renders the same frames:

    //tussock_cache/<scene>_picture/background.exr, layer_1.exr, ...
    //tussock_cache/<scene>_picture_uv1/<scene>_picture_uv1_0001.exr, _0002.exr, ...

Every file has a sidecar `<file>.tski` (format version, frame, inputs key, size, checksum;
native/include/tussock/bake_image.h) written after it, so a frame counts only when both are
complete and agree: a killed bake resumes after its last good frame, farm workers may bake
disjoint frame ranges, and a frame of another Tussock or of other inputs is never used.
With Tussock installed, each frame is verified before it is shown; a frame that is not
covered (out of date, outside the baked range, missing or corrupt) is computed live
instead and the reason printed. The worker part (PictureJob.bake_frames) touches no bpy."""

import collections
import hashlib
import json
import os
import time
import types
from concurrent.futures import ThreadPoolExecutor

import bpy
import numpy as np

from .. import cache, compat, native
from ..nodes import picture_compositor
from ..wind import runtime as wind_runtime
from . import frames, layers

WRITERS = max(1, min(4, os.cpu_count() or 1))  # threads writing EXR files in a bake
RECORD = "tussock_picture_bake"  # scene custom property: what was baked, for checking
# a temporary file of the plate or a layer untouched this long is a killed bake's (seconds;
# writing one takes well under a second)
STALE_TEMPORARY_S = 600
SIDECAR = ".tski"  # TSK_BAKE_IMAGE_SIDECAR
_verified = {}  # path -> (stat signature, info dict or error text)
_notes = {}     # scene name -> last reason printed


def base_name(scene):
    return cache.safe_name(scene.name) + "_picture"


def uv_name(scene, i):
    """Folder and file stem of layer i's UV sequence (i from 1)."""
    return f"{base_name(scene)}_uv{i}"


def uv_file(stem, frame):
    return f"{stem}_{frame:04d}.exr"  # Blender's image sequences count frames in the name


def static_files(count):
    return ["background.exr"] + [f"layer_{i}.exr" for i in range(1, count + 1)]


def _layer_values(layer):
    """A layer's motion settings as plain values (frames.layer_kwargs reads these)."""
    names = ("cell_x", "cell_y", "lambda_x", "lambda_y", "rigidity", "root", "root_auto",
             "root_line", "root_height")
    return types.SimpleNamespace(**{n: getattr(layer, n) for n in names})


def inputs_key(scene):
    """A digest of what a baked picture frame depends on and Tussock can check cheaply at
    every frame: the applied picture description, each layer's motion, the loop, the
    scene's wind settings and placement, the wind sources as they are at the first frame,
    the first frame and the frame rate. Keyframed wind sources later in the range are not
    part of it (a new bake checks them: see PictureJob.frames_key)."""
    s = scene.tussock_picture
    motion = [sorted(vars(_layer_values(x)).items()) for x in s.layers]
    parts = [s.applied, repr(motion), s.loop_frames, frames.wind_placement(scene),
             scene.frame_start, wind_runtime.fps_of(scene),
             scene.render.fps_base / scene.render.fps, wind_runtime.settings_key(scene),
             wind_runtime.sources(scene, scene.frame_start).tobytes().hex()]
    return hashlib.sha256(repr(parts).encode()).hexdigest()


class PictureJob(cache.Job):
    """Everything needed to bake a scene's animated picture, read from Blender on the main
    thread; bake_frames runs in the worker."""

    def __init__(self, scene, root):
        s = scene.tussock_picture
        if not s.applied:
            raise ValueError("the picture is not animated yet: run Animate Picture first")
        if scene.frame_start < 0:
            raise ValueError(f"picture bakes number their files by frame: the first frame "
                             f"must be 0 or later, not {scene.frame_start}")
        self.spec = json.loads(s.applied)
        self.count = len(self.spec.get("layers", []))  # the layers Animate Picture built
        if len(s.layers) < self.count:
            raise ValueError("a layer was removed since Animate Picture: run it again")
        _tree_with_nodes(scene, self.count)  # refused before anything is written
        self.name = scene.name
        self.scene_name = scene.name
        self.range = (scene.frame_start, scene.frame_end)
        self.loop = s.loop_frames
        self.dt = scene.render.fps_base / scene.render.fps
        self.layer_values = [_layer_values(x) for x in s.layers[:self.count]]
        self.placement = frames.wind_placement(scene)
        self.wind_kwargs = wind_runtime.wind_kwargs(scene)
        self.fps = wind_runtime.fps_of(scene)
        self.key = inputs_key(scene)
        # the built picture of this session if there is one; else the worker builds it
        entry = frames._pictures.get(scene.name)
        self.built = entry["built"] if entry and entry["key"] == s.applied else None
        paths = [self.spec.get("filepath", "")] + [
            x.get(k, "") for x in self.spec.get("layers", [])
            for k in ("mask_path", "strokes_path", "scale_map_path")]
        self.paths = {p: frames.abspath(p) for p in paths}
        self.mask_images = {x["mask_image"]: frames.image_pixels(x["mask_image"])
                            for x in self.spec.get("layers", [])
                            if x.get("mask_mode") == "IMAGE" and x.get("mask_image")}
        # wind sources at every frame the fields need, read now (F-curves need bpy)
        last = self.range[1] if self.loop <= 0 else \
            max(self.range[1], self.range[0] + 3 * self.loop - 1)
        self.sources = {f: wind_runtime.sources(scene, f)
                        for f in range(self.range[0], last + 1)}
        digest = hashlib.sha256(self.key.encode())
        for f in sorted(self.sources):
            digest.update(self.sources[f].tobytes())
        self.frames_key = int.from_bytes(digest.digest()[:8], "little")  # in every sidecar
        base = base_name(scene)
        self.folder = os.path.join(root, base)
        self.rel_folder = cache.CACHE_DIR + "/" + base
        self.uv_stems = [uv_name(scene, i) for i in range(1, self.count + 1)]
        self.uv_folders = [os.path.join(root, stem) for stem in self.uv_stems]

    # ---- worker part: native only ----------------------------------------------------

    def outputs(self):
        return [self.folder] + self.uv_folders

    def uv_path(self, i, frame):
        return os.path.join(self.uv_folders[i], uv_file(self.uv_stems[i], frame))

    def _good(self, lib, path, frame):
        """True when path and its sidecar verify and belong to this bake; raises on a file
        of another Tussock (the artist must free the bake)."""
        try:
            info = lib.bake_image_info(path)
        except lib.Error as exc:
            if "another Tussock" in str(exc):
                raise
            return False
        return info["frame"] == frame and info["key"] == self.frames_key

    def _picture(self):
        if self.built is None:
            self.built = layers.build(self.spec, lambda name: self.mask_images.get(name),
                                      lambda path: self.paths.get(path, path))
        return self.built

    def steps(self, frame_list, progress):
        """Writes the frames of frame_list whose files do not verify (resume), and the
        background plate and layers at rest if needed; yields between frames (see
        cache.Job.steps)."""
        lib = native.require()
        # Temporary files of a killed bake: those of this bake's own frames, and those of the
        # plate and layers once they are old. Another worker of a split bake may be writing
        # its frames, or the same plate and layers (every worker that finds them missing
        # writes them; the last rename wins, with the same bytes), right now.
        mine = {uv_file(stem, f) for stem in self.uv_stems for f in frame_list}
        for folder in [self.folder] + self.uv_folders:
            os.makedirs(folder, exist_ok=True)
            for name in os.listdir(folder):
                if ".tmp" not in name:
                    continue
                path = os.path.join(folder, name)
                # an EXR's temporary is `<file>.tmp<pid>.exr`, its sidecar's `<file>.tski.tmp<pid>`
                base = name.split(".tmp")[0].removesuffix(SIDECAR)
                try:
                    if base in mine or \
                            time.time() - os.stat(path).st_mtime > STALE_TEMPORARY_S:
                        os.remove(path)
                except FileNotFoundError:  # its writer renamed or removed it meanwhile
                    pass
        statics = [os.path.join(self.folder, n) for n in static_files(self.count)]
        todo = []
        for f in frame_list:
            if all(self._good(lib, self.uv_path(i, f), f) for i in range(self.count)):
                progress()
            else:
                todo.append(f)
        missing = [p for p in statics if not self._good(lib, p, 0)]
        if not todo and not missing:
            return
        b = self._picture()
        if lib.picture_layer_count(b.handle) != self.count:
            raise ValueError("the picture's layers changed since Animate Picture: run it again")
        w, h = b.width, b.height
        buf = np.empty(w * h * 4, np.float32)
        for path in missing:
            if os.path.basename(path) == "background.exr":
                lib.picture_read_background(b.handle, buf)
            else:
                lib.picture_read_layer(b.handle, statics.index(path) - 1, buf)
            lib.bake_write_image(path, 0, self.frames_key, buf, w, h)
        if todo:
            yield from self._bake_uv(lib, b, todo, progress)

    def _needs(self, frame):
        """[(wind frame, weight)] whose fields make `frame`."""
        if self.loop <= 0:
            return [(frame, 1.0)]
        return list(frames.loop_frames_of(frame, self.range[0], self.loop))

    def _bake_uv(self, lib, b, todo, progress):
        w, h = b.width, b.height
        xs, ys, fw, fh = frames.sample_points(self.placement, w, h)
        kwargs = []
        for i, values in enumerate(self.layer_values):
            kw = frames.layer_kwargs(values, self.dt, h)
            if b.scale_maps[i] is not None:
                kw["scale_map"] = b.scale_maps[i]
            kwargs.append(kw)
        zero = np.zeros(fw * fh, np.float32)
        vx, vy = np.empty(fw * fh, np.float32), np.empty(fw * fh, np.float32)
        wind = wind_runtime.Stepper(self.wind_kwargs, self.range[0], self.fps,
                                    lambda f: self.sources.get(f, np.zeros((0, 8), np.float32)))
        # the wind only steps forward: visit the wind frames in order, keep a field only
        # until the last frame that needs it is written
        needs = {f: self._needs(f) for f in todo}
        order = sorted(todo, key=lambda f: max(g for g, _ in needs[f]))
        last_use = {}  # wind frame -> index in `order` of the last frame that needs it
        for k, f in enumerate(order):
            for g, _ in needs[f]:
                last_use[g] = k
        fields, k = {}, 0
        with _Writers(progress) as writers:
            for g in sorted(last_use):
                yield
                if g <= self.range[0]:  # the continuum is at rest until the first step
                    fields[g] = (zero, zero)
                else:
                    t = wind.advance(g)
                    sx, sy = np.empty(fw * fh, np.float32), np.empty(fw * fh, np.float32)
                    lib.wind_sample(wind.handle, t, xs, ys, vx, vy, sx, sy)
                    fields[g] = (sx, sy)
                while k < len(order) and max(x for x, _ in needs[order[k]]) == g:
                    f = order[k]
                    yield
                    if self.loop <= 0:
                        fx, fy = fields[f]
                    else:
                        (g1, _), (g0, a) = needs[f]
                        fx, fy = frames.loop_mix(fields[g1][0], fields[g1][1], fields[g0][0],
                                                 fields[g0][1], a)
                    for i in range(self.count):
                        uv = np.empty(w * h * 4, np.float32)  # owned by its write until done
                        try:
                            lib.picture_layer_frame(b.handle, i, fx, fy, fw, fh, uv=uv,
                                                    field_y_up=True, uv_bottom_up=False,
                                                    **kwargs[i])
                        except native.Error as exc:
                            raise native.Error(f"layer {i + 1}: {exc}") from None
                        writers.write(lib.bake_write_image, (self.uv_path(i, f), f,
                                                             self.frames_key, uv, w, h),
                                      last=i == self.count - 1)
                    for x, _ in needs[f]:
                        if last_use[x] == k:
                            del fields[x]
                    k += 1

    def assemble(self):
        """Nothing to assemble (Blender reads the sequence); True when every frame of the
        range and the still images are there (their sidecars exist)."""
        paths = [os.path.join(self.folder, n) for n in static_files(self.count)]
        paths += [self.uv_path(i, f) for i in range(self.count)
                  for f in range(self.range[0], self.range[1] + 1)]
        return all(os.path.exists(p + SIDECAR) for p in paths)

    # ---- main thread ---------------------------------------------------------------------

    def wire(self, scene):
        """Points the compositor at the baked files (stock Image nodes; the UV passes as
        image sequences whose file numbers are scene frames) and records the bake."""
        tree = _tree_with_nodes(scene, self.count)
        rel = [self.rel_folder + "/" + n for n in static_files(self.count)]
        rel_uv = [cache.CACHE_DIR + "/" + stem + "/" + uv_file(stem, self.range[0])
                  for stem in self.uv_stems]
        names = [f"Tussock Baked Background ({self.scene_name})"]
        names += [f"Tussock Baked Layer {i} ({self.scene_name})" for i in range(1, self.count + 1)]
        names += [f"Tussock Baked UV {i} ({self.scene_name})" for i in range(1, self.count + 1)]
        imgs = []
        for name, path, seq in zip(names, rel + rel_uv, [False] * len(rel) + [True] * self.count):
            img = bpy.data.images.get(name)
            if img is None:
                img = bpy.data.images.new(name, 4, 4, alpha=True, float_buffer=True)
            img.source = "SEQUENCE" if seq else "FILE"
            img.filepath = path
            img.colorspace_settings.name = "Non-Color"
            img.alpha_mode = "PREMUL"
            img.use_half_precision = False  # UV passes need every bit of float32
            img.reload()  # a bake again may have changed the files Blender holds
            imgs.append(img)
        scene[RECORD] = {"key": self.key, "frames_key": f"{self.frames_key:016x}",
                         "range": list(self.range), "layers": self.count, "images": names}
        n = self.count
        picture_compositor.set_images(tree, imgs[0], list(zip(imgs[1:1 + n], imgs[1 + n:])),
                                      sequence=(self.range[0], self.range[1] - self.range[0] + 1))
        _verified.clear()
        _notes.pop(scene.name, None)
        serves(scene, scene.frame_current)  # live again if this frame is not baked yet


class _Writers:
    """Writes files on a few threads: compressing an EXR (zlib) costs far more than
    computing its UV pass, and the native writer releases the GIL. At most WRITERS writes
    wait at a time (each holds its frame's buffer); progress() is called in order, once
    per frame, when its last file is written; the first error is raised."""

    def __init__(self, progress):
        self.progress = progress
        self.pending = collections.deque()

    def __enter__(self):
        self.pool = ThreadPoolExecutor(max_workers=WRITERS)
        return self

    def write(self, fn, args, last):
        self.drain(WRITERS)
        self.pending.append((self.pool.submit(fn, *args), last))

    def drain(self, limit=0):
        while len(self.pending) > limit:
            fut, last = self.pending.popleft()
            fut.result()
            if last:
                self.progress()

    def __exit__(self, kind, *_):
        try:
            if kind is None:
                self.drain()
            else:  # already failing or cancelled: let the started writes end, keep the error
                for fut, _last in self.pending:
                    fut.exception()
        finally:
            self.pool.shutdown(wait=True)


def _tree_with_nodes(scene, count):
    tree = compat.compositor_tree(scene, create=False)
    need = ["Tussock Background"] + [f"Tussock {k} {i}" for i in range(1, count + 1)
                                     for k in ("Layer", "UV")]
    missing = [n for n in need if tree is None or tree.nodes.get(n) is None]
    if missing:
        raise ValueError(f"the compositor has no node '{missing[0]}': run Animate Picture "
                         "again, then bake")
    return tree


# ---- is a frame baked? (main thread, Tussock installed) ---------------------------------

def _signature(path):
    try:
        a, b = os.stat(path), os.stat(path + SIDECAR)
    except OSError:
        return None
    return (a.st_mtime_ns, a.st_size, a.st_ino, b.st_mtime_ns, b.st_size, b.st_ino)


def _verify(path, frame, frames_key):
    """None when path is a good frame of this bake, else the reason. Results are kept
    while the files do not change, so playing a baked range reads each file once."""
    sig = _signature(path)
    got = _verified.get(path)
    if got is None or got[0] != sig or sig is None:
        try:
            got = (sig, native.lib.bake_image_info(path))
        except native.Error as exc:
            got = (sig, str(exc))
        _verified[path] = got
    info = got[1]
    if isinstance(info, str):
        return info
    if info["frame"] != frame or f"{info['key']:016x}" != frames_key:
        return f"'{path}' belongs to another bake (frame {info['frame']}, other inputs)"
    return None


def frame_problem(scene, frame):
    """None when the compositor may show the baked `frame` of the scene's picture, else
    a sentence saying why not (what the artist reads)."""
    rec = scene.get(RECORD)
    if rec is None:
        return "the picture is not baked"
    if not native.available():
        return "Tussock's native library is missing"
    if rec.get("key") != inputs_key(scene):
        return ("the picture bake is out of date (the picture, its motion, the wind, the "
                "first frame or the frame rate changed since): showing live frames; bake again")
    start, end = (int(v) for v in rec["range"])
    if not start <= frame <= end:
        return (f"frame {frame} is outside the baked frames {start}-{end}: showing the live "
                "frame; bake again to cover the new frame range")
    try:
        root = cache.cache_root()
    except ValueError as exc:
        return str(exc)
    n = int(rec["layers"])
    paths = [(os.path.join(root, base_name(scene), x), 0) for x in static_files(n)]
    paths += [(os.path.join(root, uv_name(scene, i), uv_file(uv_name(scene, i), frame)), frame)
              for i in range(1, n + 1)]
    for path, f in paths:
        why = _verify(path, f, rec["frames_key"])
        if why is not None:
            return f"baked frame {frame} cannot be used: {why}; showing the live frame"
    return None


def _images(scene, baked):
    """(background, [(layer image, UV image)]) the compositor should read."""
    s = scene.tussock_picture
    if not baked:
        return s.background_image, [(x.layer_image, x.uv_image) for x in s.images]
    names = scene[RECORD]["images"]
    imgs = [bpy.data.images.get(n) for n in names]
    n = (len(imgs) - 1) // 2
    return imgs[0], list(zip(imgs[1:1 + n], imgs[1 + n:]))


def _rewire(scene, baked):
    tree = compat.compositor_tree(scene, create=False)
    if tree is None:
        return
    bg, pairs = _images(scene, baked)
    if bg is None or any(x is None for p in pairs for x in p):
        return
    rng = scene[RECORD]["range"] if baked else None
    changed = picture_compositor.set_images(
        tree, bg, pairs, sequence=(int(rng[0]), int(rng[1]) - int(rng[0]) + 1) if baked else None)
    if changed and not baked:  # the live images were not kept up while the bake showed
        frames._written.pop(scene.name, None)


def serves(scene, frame):
    """Chooses the compositor's images for `frame`: the baked files when they hold it
    (True), else Tussock's live images (False; the reason is printed once)."""
    if scene.get(RECORD) is None:
        return False
    why = frame_problem(scene, frame)
    _rewire(scene, why is None)
    if why is not None and _notes.get(scene.name) != why:
        print(f"Tussock: {scene.name}: {why}")
    _notes[scene.name] = why
    return why is None


def wire_for_save(scene):
    """Before a save: a bake that is up to date is wired in whatever the current frame,
    so that the saved .blend renders from the files where Tussock is absent."""
    if scene.get(RECORD) is not None and native.available() \
            and scene[RECORD].get("key") == inputs_key(scene):
        _rewire(scene, True)


# ---- the job source (see addon/cache.py) -------------------------------------------------

def jobs(scene, root):
    """The scene's picture job, or none when no picture is animated."""
    s = getattr(scene, "tussock_picture", None)
    return [PictureJob(scene, root)] if s is not None and s.applied else []


def cache_key(obj, scene):
    return None  # a picture is baked into image sequences, not a Mesh Cache


def restore(obj, scene):
    pass


def status(scene):
    """(text, ok) for the Bake panel, or None when the scene's picture is not baked."""
    rec = scene.get(RECORD)
    if rec is None:
        return None
    if not native.available() or rec.get("key") != inputs_key(scene):
        return "Picture: bake out of date, bake again", False
    start, end = (int(v) for v in rec["range"])
    why = _notes.get(scene.name)
    if why:
        return f"Picture: frames {start}-{end}; {why}", False
    return f"Picture: frames {start}-{end}", True


def free(scene, root, freed=()):
    """Deletes the scene's picture caches, restores the live compositor wiring and
    removes the baked images. Returns 1 if there was a bake, else 0."""
    rec = scene.get(RECORD)
    base = base_name(scene)
    folders = [os.path.join(root, base)]
    if os.path.isdir(root):
        folders += [os.path.join(root, d) for d in os.listdir(root)
                    if d.startswith(base + "_uv") and d[len(base) + 3:].isdigit()]
    found = rec is not None
    for folder in folders:
        if not os.path.isdir(folder):
            continue
        found = True
        for name in os.listdir(folder):
            if name.endswith((".exr", SIDECAR)) or ".tmp" in name:
                os.remove(os.path.join(folder, name))
        if not os.listdir(folder):
            os.rmdir(folder)
    if rec is None:
        return int(found)
    _rewire(scene, False)
    names = list(rec.get("images", []))
    del scene[RECORD]
    for name in names:
        img = bpy.data.images.get(name)
        if img is not None:
            bpy.data.images.remove(img)
    _verified.clear()
    _notes.pop(scene.name, None)
    try:  # the live images hold the current frame again
        frames.update(scene)
    except (native.Error, ValueError, OSError) as exc:
        scene.tussock_picture.last_error = str(exc)
    return 1

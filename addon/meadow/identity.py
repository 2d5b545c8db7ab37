"""Which meadow is which, whatever its name: a meadow object keeps a persistent id (a custom
property given when it is made or first used), and Tussock's state of a meadow — its live
simulation, its simulated-blade objects and its patch collection — is keyed by that id, with
the library path of a linked meadow. A rename keeps the key (the owned objects are renamed to
follow); a duplicate (Shift+D, Full Copy of a scene) copies the id, so when two local objects
hold one id the newer gets a fresh one; a linked meadow's key never equals a local one's."""

import uuid

import bpy

from .. import compat

ID = "tussock_meadow_id"  # on the meadow object
OWNER = "tussock_meadow_key"  # on each object and collection a meadow owns: the meadow's key

_holder = {}  # key -> as_pointer() of the object that held it at the last scan
_scanned = None  # len(bpy.data.objects) at the last scan
born = {}  # fresh key given by the last scan -> the key its meadow was copied with
gone = set()  # keys of meadows that a scan found and a later one did not (deleted ones)
_live = set()  # the keys the last scan found


def key(obj):
    """The key of a meadow object's state. A local meadow without an id gets one now; a
    linked meadow cannot be written, so one without an id is known by its name, which is
    unique within its library."""
    ident = obj.get(ID)
    lib = obj.library
    if lib is not None:
        return f"{ident or 'name:' + obj.name}@{lib.filepath}"
    if not isinstance(ident, str) or not ident:
        ident = give_id(obj)
    return ident


def give_id(obj):
    ident = uuid.uuid4().hex
    obj[ID] = ident
    _holder[ident] = obj.as_pointer()
    return ident


def meadows():
    """Every meadow object in the file (of any scene, linked ones included)."""
    return [o for o in bpy.data.objects
            if (s := compat.settings_of(o, "tussock_meadow")) is not None and s.is_meadow]


def scan(force=False):
    """Gives each duplicated meadow a fresh id and returns the keys of every meadow object
    (a set), or None when the number of objects has not changed since the last scan (no
    object was made or removed: nothing to do). Of the local objects that hold one id, the
    one that held it at the last scan keeps it; failing that, the one whose simulated blades
    carry its name (the original: Shift+D names the copy anew), else the first by name."""
    global _scanned
    count = len(bpy.data.objects)
    if not force and count == _scanned:
        return None
    _scanned = count
    born.clear()
    found = {}
    for obj in meadows():  # one entry per meadow object, not per blade
        found.setdefault(key(obj), []).append(obj)
    for k, objs in list(found.items()):
        if len(objs) > 1:
            objs.sort(key=lambda o: (o.as_pointer() != _holder.get(k), not _blades_named_for(o, k),
                                     o.name))
            for other in objs[1:]:
                fresh = give_id(other)
                found[fresh] = [other]
                born[fresh] = k
            found[k] = objs[:1]
        _holder[k] = found[k][0].as_pointer()
    for k in [k for k in _holder if k not in found]:
        del _holder[k]
    gone.update(_live.difference(found))  # (a key given to a meadow still being made is
    gone.difference_update(found)         # not a meadow's yet); back by undo
    _live.clear()
    _live.update(found)
    return set(found)


def _blades_named_for(obj, k):
    child = bpy.data.objects.get(chunk_name(obj, 0))
    return child is not None and child.get(OWNER) == k


def meadow_of(thing, scene=None):
    """The meadow object (of `scene`, else of the file) that owns `thing`, or None. Things
    made before meadows had ids name their meadow instead."""
    k = thing.get(OWNER)
    if k is not None:
        return find(k, scene)
    obj = (scene.objects if scene is not None else bpy.data.objects).get(
        thing.get("tussock_meadow_name", ""))
    s = compat.settings_of(obj, "tussock_meadow")
    return obj if s is not None and s.is_meadow else None


def find(k, scene=None):
    """The meadow object (of `scene`, else of the file) whose key is `k`, or None."""
    for obj in (scene.objects if scene is not None else bpy.data.objects):  # one check each
        if (obj.get(ID) is not None or obj.library is not None) and key(obj) == k:
            s = compat.settings_of(obj, "tussock_meadow")
            if s is not None and s.is_meadow:
                return obj
    return None


def adopt(obj, thing, old_name):
    """True if `thing` is meadow `obj`'s: owned by its key, or made before ids by a meadow
    of `obj`'s name (`old_name` is what it was made for), which it now gets as owner."""
    k = key(obj)
    owner = thing.get(OWNER)
    if owner is not None:
        return owner == k
    if old_name is not None and old_name == obj.name and thing.library is None:
        thing[OWNER] = k
        return True
    return False


class PerMeadow(dict):
    """Tussock's state of each meadow, by key (see key()): what a module keeps per meadow
    and lets go of when the meadow is forgotten or gone."""

    def forget(self, obj=None):
        """Lets go of meadow object `obj`'s entry, or of every entry."""
        if obj is None:
            self.clear()
        else:
            self.pop(key(obj), None)

    def keep_only(self, live):
        """Lets go of the entries of meadows whose keys are not in `live`."""
        for which in [k for k in self if k not in live]:
            del self[which]


def forget():
    global _scanned
    _holder.clear()
    born.clear()
    gone.clear()
    _live.clear()
    _scanned = None


def base_name(obj):
    """What the names of a meadow's own objects start with: its name, and for a linked
    meadow its library's too (a local meadow may have the same name)."""
    return obj.name if obj.library is None else f"{obj.name} [{obj.library.name}]"


def chunk_name(obj, key):
    """Name of the meadow's chunk object `key`: i (0 the first, which a bake writes) for the
    chunks shown in the viewport, ("render", i) for the render chunks."""
    if isinstance(key, tuple):
        return compat.id_name(base_name(obj), f" blades render {key[1] + 1}")
    return compat.id_name(base_name(obj), " blades" + (f" {key + 1}" if key else ""))

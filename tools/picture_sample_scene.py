"""The sample picture (samples/picture/) described as an artist does in the Picture panel:
the photo, a grass layer rooted at the bottom and a crown layer. Shared by the demo, the
docs' pictures, the picture bake benchmark and the farm test."""

import os

FOLDER = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                      "samples", "picture")
FILES = ("meadow.png", "grass_mask.png", "crown_mask.png")


def describe(settings, where=FOLDER, crown_waves=True):
    """Fills a scene's tussock_picture `settings` (before Animate Picture) with the sample's
    photo and its two layers. `where`: the folder of FILES, or "//" for copies beside the
    saved .blend. `crown_waves`: the crown sways in longer waves (48 x 12 px) than the
    grass, as the docs show it. Returns (grass, crown)."""
    def path(name):
        return "//" + name if where == "//" else os.path.join(where, name)
    settings.filepath = path("meadow.png")
    grass = settings.layers.add()
    grass.name, grass.mask_path, grass.root = "Grass", path("grass_mask.png"), "TOP"
    crown = settings.layers.add()
    crown.name, crown.mask_path = "Crown", path("crown_mask.png")
    if crown_waves:
        crown.lambda_x, crown.lambda_y = 48.0, 12.0
    return grass, crown

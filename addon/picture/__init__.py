"""Pictures that sway: a still picture's vegetation layers moved by the scene's shared wind
(seed 004), drawn by a compositor tree that Tussock owns."""

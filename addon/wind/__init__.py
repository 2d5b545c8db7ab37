"""One wind for everything: scene sines and gusts, a stable-fluids grid driven by wind
source empties, the wave continuum; sampled by meadows, trees and pictures alike."""

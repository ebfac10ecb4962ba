"""Linkage synthesis: design a mechanism from what it must do (``mechsolve synth``).

* :mod:`.fourbar` crank-rockers from the rocker's limit positions (extreme distances,
  time ratio);
* :mod:`.slidercrank` offset slider-cranks for a stroke and a time ratio;
* :mod:`.guidebar` oscillating guide bars (slotted levers) for a frame and a time ratio;
* :mod:`.motion_gen` four-bars through three positions of a coupler line;
* :mod:`.window` the input window that makes a point's path straightest;
* :mod:`.writer` ready mechanism files of the designs; :mod:`.problem` the problem file.
"""

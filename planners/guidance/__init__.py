"""Guided sampling shared by the environments and the learned samplers (numpy + numba only).

Egocentric multi-scale views of the map and tree (``egocentric``), the tree's exploration frontier
(``frontier``), and the guided action space that turns an action class into samples (``guided``).
"""

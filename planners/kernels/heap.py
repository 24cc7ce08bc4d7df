"""An indexed binary min-heap with decrease-key, compiled: the priority queue of the grid and voxel searches.

The heap lives in three arrays the caller owns: ``keys`` and ``items`` (its slots) and ``pos`` (per item, its slot;
-1 never queued, -2 taken off). So a search over ``n`` cells holds at most ``n`` entries, never a stale one.

* ``heap_lower(keys, items, pos, size, k, v)``: put ``v`` on the heap with key ``k``, or move it up after its key
  fell to ``k``; returns the heap's new size.
* ``heap_pop(keys, items, pos, size)``: take the least-key entry off (read ``keys[0]``, ``items[0]`` first); returns
  the new size.
"""

from __future__ import annotations

import numba as nb


@nb.njit(cache=True)
def _place(keys, items, pos, j, k, v):
    """Move entry (``k``, ``v``) up the heap from slot ``j`` to where it belongs."""
    while j > 0:
        p = (j - 1) >> 1
        if keys[p] <= k:
            break
        keys[j] = keys[p]
        items[j] = items[p]
        pos[items[j]] = j
        j = p
    keys[j] = k
    items[j] = v
    pos[v] = j


@nb.njit(cache=True)
def heap_lower(keys, items, pos, size, k, v):
    """Put ``v`` on the heap with key ``k``, or move it up after its key fell to ``k``: the heap's new size."""
    if pos[v] == -1:
        _place(keys, items, pos, size, k, v)
        return size + 1
    _place(keys, items, pos, pos[v], k, v)
    return size


@nb.njit(cache=True)
def heap_pop(keys, items, pos, size):
    """Take the least-key entry (``keys[0]``, ``items[0]``, read by the caller first) off the heap: the new size."""
    pos[items[0]] = -2
    size -= 1
    if size == 0:
        return 0
    k, v = keys[size], items[size]
    j = 0
    while True:
        c = 2 * j + 1
        if c >= size:
            break
        if c + 1 < size and keys[c + 1] < keys[c]:
            c += 1
        if keys[c] >= k:
            break
        keys[j] = keys[c]
        items[j] = items[c]
        pos[items[j]] = j
        j = c
    keys[j] = k
    items[j] = v
    pos[v] = j
    return size

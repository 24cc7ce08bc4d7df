"""Where maps come from and what is known about them.

File readers by format (``readers``, ``rosmap``), the MovingAI benchmarks (``movingai``), seeded
generators of the five map families (``generators``), exact grid searches (``gridsearch``) and map
sets: maps with queries, split into training, validation, tuning and test parts (``mapset``).
"""

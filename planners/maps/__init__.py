"""Where maps come from and what is known about them.

File readers by format (``readers``, ``rosmap``), the MovingAI benchmarks (``movingai``), seeded
generators of the five map families (``generators``) and exact grid searches (``gridsearch``).
"""

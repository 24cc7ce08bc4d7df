"""Where maps come from and what is known about them: file readers (ROS map_server), seeded generators and exact grid searches (distance fields, shortest paths)."""

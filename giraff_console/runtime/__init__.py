"""The one composition root: the robot built from the settings and a front end's
options, started and stopped as one (robot.py; design.md, "The shape")."""

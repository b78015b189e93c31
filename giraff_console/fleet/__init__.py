"""The fleet link: the robot as a VDA 5050 vehicle over an MQTT broker, and a master
control's client of such vehicles (issue 28)."""

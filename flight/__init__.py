"""Flight: the JSBSim quadcopter, its flight controller, the MAVLink vehicle and the safety envelope."""

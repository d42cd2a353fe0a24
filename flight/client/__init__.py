"""The agent's MAVLink client, in parts; :mod:`flight.vehicle` assembles them into
:class:`~flight.vehicle.VehicleClient` and is the module to import from.

:mod:`~flight.client.link` owns the UDP socket and the reader thread; :mod:`~flight.client.telemetry` folds the
vehicle's messages into telemetry; :mod:`~flight.client.core` waits for answers from asyncio;
:mod:`~flight.client.commands` sends commands until their ACK and handles parameters;
:mod:`~flight.client.operations` tracks the motion command under way; :mod:`~flight.client.actions` flies;
:mod:`~flight.client.mission` and :mod:`~flight.client.mission_items` transfer and start missions;
:mod:`~flight.client.results` holds the result models. Each module's docstring names the MAVLink facts it relies on.
"""

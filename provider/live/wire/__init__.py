"""The wire (docs/contract.md §3, §10): what every client receives.

* :mod:`.message`: one JSON object per coefficient message, and its JSON Schema
  (``sh9_message.schema.json``);
* :mod:`.export`: the same message in other engines' layouts (``to=FORMAT``);
* :mod:`.mqtt_link`: an MQTT broker's URL and a configured paho client, for the lighting
  published (``--mqtt``) and a lux meter subscribed to (``--lux mqtt[s]://...``).

May import: :mod:`provider.core` (errors, conventions), paho-mqtt. Nothing else of the live
service.
"""

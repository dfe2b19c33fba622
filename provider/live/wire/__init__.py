"""The wire (docs/contract.md §3, §10): what every client receives.

* :mod:`.message`: one JSON object per coefficient message, and its JSON Schema
  (``sh9_message.schema.json``);
* :mod:`.export`: the same message in other engines' layouts (``to=FORMAT``).

May import: :mod:`provider.core` (errors, conventions). Nothing else of the live service.
"""

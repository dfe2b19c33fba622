"""The one error type every layer shares.

It lives at the bottom of the package (the maths) so that the image reader, the engine,
the live service and the command line can all raise and catch it without importing each
other.
"""


class InputError(ValueError):
    """The input cannot be turned into lighting; the message says why and what to do."""

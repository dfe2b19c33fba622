"""Our SH9, lights and cube in each consumer's own convention (numpy only, no I/O).

* :mod:`.formats`: the exports (three.js, Babylon.js, Filament, Unity, Unreal, glTF, ...);
* :mod:`.notes`: what each format is, where it was read, how to use it (data only).

May import: geometry, :mod:`provider.core.reflections` (the glTF IBL images). Nothing of I/O.
"""

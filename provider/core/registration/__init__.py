"""Registration: the camera's pose in the headset's world (docs/contract.md §13), and where a
mirror ball is in a frame.

* :mod:`.pose`: :func:`~provider.core.registration.pose.find_marker`, a printed marker's
  pose in a panorama, and poses averaged;
* :mod:`.marker_detect`, :mod:`.marker_print`: the marker named, detected, printed;
* :mod:`.xmp_pose`: a still's gravity from its XMP;
* :mod:`.ball`: a mirror ball located in a frame.

May import: geometry. Not radiometry or the products.
"""

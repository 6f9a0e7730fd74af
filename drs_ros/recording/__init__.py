"""What the node records, and how: the bytes of the messages and the files that hold them.

* ``cdr``: exact CDR serialisation, the bytes a ROS 2 subscriber receives (``diagnostic_cdr``:
  a DiagnosticArray of text packed directly, for the effect record and diagnostics);
* ``msgdefs``: rosbag2's schema text and RIHS01 type hashes of a message type;
* ``qos``: QoS profiles as the ``offered_qos_profiles`` channel metadata holds them;
* ``mcap_recorder``: the rosbag2-compatible MCAP recorder (``flush_schedule``: when it flushes;
  ``bag_metadata``: the topics and the ``metadata.yaml`` document it writes);
* ``mcap_records``: the MCAP record layout, packed and unpacked by every writer and reader of
  drs; ``mcap_private``: mcap-python's private names, in one place;
* ``rerun_recorder``: the rerun recording of the mechanism and its time series (``rerun_sink``:
  its file sink watched while recording);
* ``destinations``: a new bag directory, ``.rrd`` file or live rerun URL, checked before
  anything is written; ``errors``: the recorders' errors;
* ``rerun_cli``: the rerun command line (``rerun rrd verify``) with its analytics off.

The modules are imported one by one (``from drs_ros.recording import cdr``): rerun and mcap load
only where they are used.
"""

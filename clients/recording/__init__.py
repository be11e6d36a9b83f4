"""Record a bridge's topics into MCAP files and replay them into a bridge.

``riverbridge record`` (:mod:`clients.recording.record_cli`) subscribes to every topic with
``cbor-raw`` and writes the bridge's CDR bytes with ROS 2 schemas (:mod:`.mcap_file`), so
Foxglove/Lichtblick, ``ros2 bag`` and rosbags read the files. ``riverbridge play``
(:mod:`clients.recording.play_cli`) publishes a recording back at its recorded timing.
docs/recording.md has the details: times, stamps, crash safety, throughput.
"""

"""Reading bags: a bag's files and metadata, every byte verified (MCAP and rosbag2's
sqlite3), the records decoded, the drs nodes a bag holds and what it says of their run."""

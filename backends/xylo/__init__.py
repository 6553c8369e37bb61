"""SynSense Xylo Audio 2 (SYNS61201) through Rockpool: the import of its samna-free parts (:mod:`.compat`)."""

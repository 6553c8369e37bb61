"""SynSense Speck / DYNAP-CNN through Sinabs: the import of its samna-free parts (:mod:`.compat`)."""

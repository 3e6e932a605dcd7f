"""A live view of the twbr graph, and of any bag, in the Rerun web viewer."""

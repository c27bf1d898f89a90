"""(Being written.)"""
ENTRY_POINTS = {}

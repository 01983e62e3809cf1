"""methods/event_driven"""

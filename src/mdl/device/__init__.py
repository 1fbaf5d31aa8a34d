"""src/mdl/device"""

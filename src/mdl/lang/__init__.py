"""src/mdl/lang"""

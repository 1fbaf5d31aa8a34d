"""src/mdl/values"""

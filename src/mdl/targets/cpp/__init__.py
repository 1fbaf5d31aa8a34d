"""src/mdl/targets/cpp"""
